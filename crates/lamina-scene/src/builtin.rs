//! Built-in scenes that need no files: the demo's three panels (a leaf lit from the front,
//! the same leaf lit from behind, a small bush under a low sun behind it).
//!
//! The leaf material is passed in (the CLI makes a procedural one), so this module stays
//! free of texture generation.

use crate::cards::{LeafCard, append_cards};
use crate::file::CardRow;
use crate::scene::*;
use glam::{Quat, Vec2, Vec3};
use std::f32::consts::TAU;
use std::sync::Arc;

/// A leaf as the built-in scenes use it: its material and its card size (m).
#[derive(Clone, Debug)]
pub struct BuiltinLeaf {
    /// The leaf's maps and parameters.
    pub material: Arc<lamina_leaf::LeafMaterial>,
    /// Card width and height (m): the leaf's bounding rectangle.
    pub size_m: Vec2,
}

fn film(width: u32, height: u32, spp: u32) -> Film {
    Film {
        width,
        height,
        spp,
        filter: PixelFilter::Gaussian {
            radius: 1.5,
            sigma: 0.5,
        },
        exposure: 0.0,
        tonemap: ToneMap::Aces,
    }
}

/// A dark-green-grey backdrop and a soil ground, shared by the leaf panels.
fn studio_materials(leaf: &BuiltinLeaf) -> Vec<Material> {
    vec![
        Material::Leaf {
            name: "leaf".into(),
            leaf: leaf.material.clone(),
        },
        Material::Diffuse {
            name: "ground".into(),
            reflectance: ColorInput::Constant(Vec3::new(0.12, 0.09, 0.06)),
            alpha: None,
        },
    ]
}

fn ground(material: u32, half: f32, y: f32) -> Mesh {
    Mesh::quad(
        Vec3::new(-half, y, half),
        Vec3::new(2.0 * half, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * half),
        material,
    )
}

/// One leaf facing the camera, its adaxial side toward the viewer, lit by a sun from
/// `sun_dir` (toward the sun) and a soft sky.
fn leaf_panel(leaf: &BuiltinLeaf, sun_dir: Vec3, sun: Vec3, size: (u32, u32), spp: u32) -> Scene {
    let h = leaf.size_m.y;
    let mut mesh = Mesh {
        material: 0,
        ..Default::default()
    };
    let card = LeafCard::new(&CardRow {
        center: [0.0, 0.0, 0.0],
        normal: [0.0, 0.15, 1.0],
        up: [0.0, 1.0, 0.0],
        width: leaf.size_m.x,
        height: leaf.size_m.y,
    })
    .expect("built-in card is valid");
    append_cards(&mut mesh, &[card]);
    let dist = 1.25 * h / (20f32.to_radians().tan() * 2.0) + 0.0;
    Scene {
        camera: Camera {
            position: Vec3::new(0.0, 0.0, dist),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 40.0,
            aperture_radius: 0.0,
            focus_distance: dist,
        },
        film: film(size.0, size.1, spp),
        integrator: Integrator::Path {
            max_depth: 8,
            rr_depth: 3,
        },
        lights: vec![Light::Sun {
            direction: sun_dir.normalize(),
            irradiance: sun,
            angular_diameter_deg: 0.53,
        }],
        sky: Some(Sky::Constant(Vec3::new(0.10, 0.13, 0.18))),
        materials: studio_materials(leaf),
        meshes: vec![mesh, ground(1, 3.0 * h, -0.75 * h)],
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// The leaf lit from the front: the sun over the viewer's shoulder.
pub fn leaf_front_lit(leaf: &BuiltinLeaf, size: (u32, u32), spp: u32) -> Scene {
    leaf_panel(leaf, Vec3::new(0.4, 0.6, 1.0), Vec3::splat(3.0), size, spp)
}

/// The same leaf lit from behind: the sun low behind the leaf, so the viewer sees the light
/// that came through it.
pub fn leaf_back_lit(leaf: &BuiltinLeaf, size: (u32, u32), spp: u32) -> Scene {
    leaf_panel(
        leaf,
        Vec3::new(-0.35, 0.65, -1.0),
        Vec3::splat(3.0),
        size,
        spp,
    )
}

/// Small deterministic hash-based random numbers for the built-in plant.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        // SplitMix64.
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Appends a tapered cylinder from `a` (radius `ra`) to `b` (radius `rb`) with `n` sides.
fn cylinder(mesh: &mut Mesh, a: Vec3, b: Vec3, ra: f32, rb: f32, n: u32) {
    let axis = (b - a).normalize();
    let frame = lamina_leaf::frame::Frame::from_normal(axis);
    let base = mesh.positions.len() as u32;
    for i in 0..n {
        let phi = TAU * i as f32 / n as f32;
        let d = frame.s * phi.cos() + frame.t * phi.sin();
        mesh.positions.push(a + d * ra);
        mesh.positions.push(b + d * rb);
        mesh.normals.push(d);
        mesh.normals.push(d);
        mesh.uvs.push(Vec2::new(i as f32 / n as f32, 0.0));
        mesh.uvs.push(Vec2::new(i as f32 / n as f32, 1.0));
    }
    for i in 0..n {
        let j = (i + 1) % n;
        let (a0, b0, a1, b1) = (
            base + 2 * i,
            base + 2 * i + 1,
            base + 2 * j,
            base + 2 * j + 1,
        );
        mesh.indices.push([a0, a1, b1]);
        mesh.indices.push([a0, b1, b0]);
    }
}

/// A small bush (after the paper's Fig. 5): a few stems that branch twice, leaves along the
/// twigs in a 137.5° spiral, tilted toward the sky and drooping, `seed`-deterministic.
/// Returns the branch mesh and the leaf cards, in metres, standing on `y = 0`.
pub fn bush(seed: u64, leaf_size: Vec2) -> (Mesh, Vec<LeafCard>) {
    let mut rng = Rng(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0x5DEE_CE66);
    let mut wood = Mesh::default();
    let mut cards = Vec::new();
    let mut stack: Vec<(Vec3, Vec3, f32, f32, u32)> = Vec::new();
    for i in 0..5 {
        let phi = TAU * (i as f32 / 5.0 + 0.1 * rng.next());
        let tilt = 0.35 + 0.25 * rng.next();
        let dir = Vec3::new(tilt.sin() * phi.cos(), tilt.cos(), tilt.sin() * phi.sin());
        stack.push((
            Vec3::new(0.0, 0.0, 0.0),
            dir,
            0.35 + 0.1 * rng.next(),
            0.012,
            0,
        ));
    }
    while let Some((start, dir, len, radius, level)) = stack.pop() {
        let end = start + dir * len;
        cylinder(&mut wood, start, end, radius, radius * 0.7, 6);
        if level < 3 {
            for k in 0..3 {
                let t = 0.45 + 0.25 * k as f32 + 0.05 * rng.next();
                let p = start + dir * len * t;
                let phi = TAU * rng.next();
                let side = lamina_leaf::frame::Frame::from_normal(dir);
                let out = side.s * phi.cos() + side.t * phi.sin();
                let nd = (dir * 0.8 + out * 0.7 + Vec3::Y * 0.2).normalize();
                stack.push((
                    p,
                    nd,
                    len * (0.5 + 0.15 * rng.next()),
                    radius * 0.6,
                    level + 1,
                ));
            }
        }
        // Leaves along the outer part of every branch, in a golden-angle spiral.
        let count = match level {
            0 => 2,
            1 => 4,
            _ => 7,
        };
        let frame = lamina_leaf::frame::Frame::from_normal(dir);
        for k in 0..count {
            let t = 0.35 + 0.65 * (k as f32 + rng.next() * 0.5) / count as f32;
            let p = start + dir * len * t;
            let phi = k as f32 * 137.5f32.to_radians() + TAU * rng.next() * 0.1;
            let out = frame.s * phi.cos() + frame.t * phi.sin();
            let scale = 0.75 + 0.5 * rng.next();
            let (w, h) = (leaf_size.x * scale, leaf_size.y * scale);
            // The blade points outward and droops; its upper side turns toward the sky.
            let tip = (out * 0.9 + Vec3::Y * (0.25 - 0.5 * rng.next()) + dir * 0.2).normalize();
            let sideways = tip.cross(Vec3::Y).normalize_or(Vec3::X);
            let mut normal = sideways.cross(tip).normalize();
            if normal.y < 0.0 {
                normal = -normal;
            }
            let twist = Quat::from_axis_angle(tip, (rng.next() - 0.5) * 0.8);
            let normal = twist * normal;
            let center = p + tip * (0.5 * h + 0.01);
            if let Ok(c) = LeafCard::new(&CardRow {
                center: center.to_array(),
                normal: normal.to_array(),
                up: tip.to_array(),
                width: w,
                height: h,
            }) {
                cards.push(c);
            }
        }
    }
    (wood, cards)
}

/// The demo's bush: the built-in plant lit by a low sun from behind and to the side, under
/// a blue sky, on soil.
pub fn bush_scene(leaf: &BuiltinLeaf, size: (u32, u32), spp: u32) -> Scene {
    let (mut wood, cards) = bush(7, leaf.size_m);
    wood.material = 2;
    let mut leaves = Mesh {
        material: 0,
        ..Default::default()
    };
    append_cards(&mut leaves, &cards);
    let mut materials = studio_materials(leaf);
    materials.push(Material::Diffuse {
        name: "bark".into(),
        reflectance: ColorInput::Constant(Vec3::new(0.09, 0.06, 0.04)),
        alpha: None,
    });
    let target = Vec3::new(0.0, 0.35, 0.0);
    let elevation = 30f32.to_radians();
    let azimuth = (180.0f32 + 35.0).to_radians();
    let sun_dir = Vec3::new(
        elevation.cos() * azimuth.sin(),
        elevation.sin(),
        elevation.cos() * azimuth.cos(),
    );
    Scene {
        camera: Camera {
            position: Vec3::new(0.0, 0.55, 1.7),
            look_at: target,
            up: Vec3::Y,
            fov_deg: 40.0,
            aperture_radius: 0.0,
            focus_distance: 1.7,
        },
        film: film(size.0, size.1, spp),
        integrator: Integrator::Path {
            max_depth: 8,
            rr_depth: 3,
        },
        lights: vec![Light::Sun {
            direction: sun_dir,
            irradiance: Vec3::new(3.2, 3.0, 2.7),
            angular_diameter_deg: 0.53,
        }],
        sky: Some(Sky::Constant(Vec3::new(0.16, 0.22, 0.32))),
        materials,
        meshes: vec![leaves, wood, ground(1, 6.0, 0.0)],
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}
