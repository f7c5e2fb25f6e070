//! A procedural canopy of leaf cards shared by the ray benchmark and the preview example:
//! `n` random cards (two triangles each) with a leaf-shaped alpha matte in a 10 m box.

use glam::{Vec2, Vec3, Vec4};
use lamina_core::{
    AlphaMask, Camera, ColorInput, Film, Integrator, Light, Material, Mesh, PixelFilter, Scene,
    Sky, ToneMap,
};
use lamina_leaf::{Texture, Wrap};
use lamina_render::sampler::hash_u32;

/// A uniform number in `[0, 1)` from a counter.
fn rnd(i: u32) -> f32 {
    (hash_u32(i) >> 8) as f32 / 16_777_216.0
}

/// A leaf-shaped matte: opaque inside a pointed ellipse along `v`, with a short petiole.
pub fn leaf_matte(size: u32) -> Texture {
    let mut texels = Vec::with_capacity((size * size) as usize);
    for y in 0..size {
        // Texture rows run top (v = 1) to bottom (v = 0).
        let v = 1.0 - (y as f32 + 0.5) / size as f32;
        for x in 0..size {
            let u = (x as f32 + 0.5) / size as f32;
            let blade = if v > 0.12 {
                let s = (v - 0.12) / 0.88;
                0.46 * (std::f32::consts::PI * s).sin().powf(0.7) * (1.0 - 0.35 * s)
            } else {
                0.0
            };
            let petiole = v <= 0.12 && (u - 0.5).abs() < 0.02;
            let a = if (u - 0.5).abs() < blade || petiole {
                1.0
            } else {
                0.0
            };
            texels.push(Vec4::new(a, a, a, 1.0));
        }
    }
    Texture::from_texels(size, size, texels, Wrap::Clamp)
}

/// Card `i`'s frame: `[across, along, normal, centre]`, a random orientation at a random
/// point of the 10 m canopy box (shared by the flat and the instanced canopy).
fn card_frame(i: u32, seed: u32) -> [Vec3; 4] {
    let k = hash_u32(seed ^ i.wrapping_mul(0x9e37_79b9)).wrapping_mul(8);
    let c = Vec3::new(
        rnd(k) * 10.0 - 5.0,
        rnd(k + 1) * 10.0,
        rnd(k + 2) * 10.0 - 5.0,
    );
    let z = 1.0 - 2.0 * rnd(k + 3);
    let phi = 2.0 * std::f32::consts::PI * rnd(k + 4);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let n = Vec3::new(r * phi.cos(), z, r * phi.sin());
    let frame = lamina_leaf::frame::Frame::from_normal(n);
    let a = 2.0 * std::f32::consts::PI * rnd(k + 5);
    let up = frame.s * a.cos() + frame.t * a.sin();
    [n.cross(up), up, n, c]
}

/// `n` leaf cards (0.1 x 0.15 m) with random positions in `[-5, 5] x [0, 10] x [-5, 5]` and
/// random orientations, all in one mesh of material 0; plus a ground quad (material 1).
pub fn canopy_meshes(n: u32, seed: u32) -> Vec<Mesh> {
    let mut m = Mesh {
        material: 0,
        ..Default::default()
    };
    for i in 0..n {
        let [side, up, _, c] = card_frame(i, seed);
        let (hw, hh) = (0.05, 0.075);
        let base = m.positions.len() as u32;
        for (du, dv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push(c + side * (du * hw) + up * (dv * hh));
            m.uvs.push(Vec2::new((du + 1.0) * 0.5, (dv + 1.0) * 0.5));
        }
        m.indices.push([base, base + 1, base + 2]);
        m.indices.push([base, base + 2, base + 3]);
    }
    let ground = Mesh {
        positions: vec![
            Vec3::new(-8.0, 0.0, 8.0),
            Vec3::new(8.0, 0.0, 8.0),
            Vec3::new(8.0, 0.0, -8.0),
            Vec3::new(-8.0, 0.0, -8.0),
        ],
        normals: vec![],
        tangents: Vec::new(),
        uvs: vec![],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material: 1,
    };
    vec![m, ground]
}

/// A full scene around [`canopy_meshes`]: sun, blue sky, leaf material with a leaf matte.
pub fn canopy_scene(n: u32, width: u32, height: u32, spp: u32) -> Scene {
    Scene {
        radiometry: Default::default(),
        camera: Camera {
            position: Vec3::new(9.0, 4.0, 14.0),
            look_at: Vec3::new(0.0, 4.0, 0.0),
            up: Vec3::Y,
            fov_deg: 55.0,
            aperture_radius: 0.0,
            focus_distance: 1.0,
        },
        film: Film {
            width,
            height,
            spp,
            filter: PixelFilter::Gaussian {
                radius: 1.5,
                sigma: 0.5,
            },
            exposure: -3.0,
            tonemap: ToneMap::Aces,
            spectral: lamina_core::SpectralMode::Rgb,
        },
        integrator: Integrator::Path {
            max_depth: 8,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![Light::Sun {
            direction: Vec3::new(-0.4, 0.8, 0.45),
            irradiance: Vec3::new(1.0, 0.95, 0.85) * 40.0,
            angular_diameter_deg: 0.53,
        }],
        sky: Some(Sky::Constant(Vec3::new(0.25, 0.4, 0.7) * 2.0)),
        materials: vec![
            Material::DiffuseTransmission {
                name: "leaf".into(),
                reflectance: ColorInput::Constant(Vec3::new(0.06, 0.18, 0.04)),
                transmittance: ColorInput::Constant(Vec3::new(0.04, 0.2, 0.03)),
                alpha: Some(AlphaMask {
                    map: leaf_matte(64),
                    use_alpha_channel: false,
                    cutoff: 0.5,
                }),
            },
            Material::Diffuse {
                name: "ground".into(),
                reflectance: ColorInput::Constant(Vec3::new(0.3, 0.25, 0.2)),
                alpha: None,
            },
        ],
        meshes: canopy_meshes(n, 1),
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// The placements of [`canopy_meshes`]' cards as object-to-world transforms of a card in
/// the `xy` plane (`x` across, `y` along the leaf, `+z` the front), in the same order.
#[allow(dead_code)] // used by the ray benchmark, not by the example
pub fn canopy_transforms(n: u32, seed: u32) -> Vec<glam::Affine3A> {
    (0..n)
        .map(|i| {
            let [side, up, n, c] = card_frame(i, seed);
            glam::Affine3A::from_cols(side.into(), up.into(), n.into(), c.into())
        })
        .collect()
}

/// A card of [`canopy_meshes`] in object space: 0.1 x 0.15 m in the `xy` plane, centred.
#[allow(dead_code)] // used by the ray benchmark, not by the example
pub fn card_mesh() -> Mesh {
    let (hw, hh) = (0.05, 0.075);
    Mesh {
        positions: [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .map(|&(du, dv)| Vec3::new(du * hw, dv * hh, 0.0))
            .collect(),
        uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material: 0,
        ..Default::default()
    }
}

/// A curved leaf of the card's size: 4 x 8 quads (64 triangles), the midrib drooping and
/// the edges cupped (non-planar quads, so no parallelograms).
#[allow(dead_code)] // used by the ray benchmark, not by the example
pub fn curved_leaf_mesh() -> Mesh {
    let (hw, hh) = (0.05, 0.075);
    let (cols, rows) = (4u32, 8u32);
    let mut m = Mesh {
        material: 0,
        ..Default::default()
    };
    for j in 0..=rows {
        for i in 0..=cols {
            let (u, v) = (i as f32 / cols as f32, j as f32 / rows as f32);
            let (x, y) = (u * 2.0 - 1.0, v * 2.0 - 1.0);
            let z = -0.03 * (v * v) + 0.015 * x * x;
            m.positions.push(Vec3::new(x * hw, y * hh, z));
            m.uvs.push(Vec2::new(u, v));
        }
    }
    for j in 0..rows {
        for i in 0..cols {
            let a = j * (cols + 1) + i;
            let (b, c, d) = (a + 1, a + cols + 2, a + cols + 1);
            m.indices.push([a, b, c]);
            m.indices.push([a, c, d]);
        }
    }
    m
}

/// [`canopy_scene`] with its cards as instances of one prototype `proto` (placed like the
/// cards); the ground stays a world mesh.
#[allow(dead_code)] // used by the ray benchmark, not by the example
pub fn instanced_canopy_scene(n: u32, width: u32, height: u32, proto: Mesh) -> Scene {
    let mut s = canopy_scene(0, width, height, 1);
    s.meshes.retain(|m| m.material == 1);
    s.prototypes = vec![lamina_core::Prototype {
        name: "leaf".into(),
        meshes: vec![proto],
    }];
    s.instances = canopy_transforms(n, 1)
        .into_iter()
        .map(|transform| lamina_core::Instance {
            prototype: 0,
            transform,
        })
        .collect();
    s
}
