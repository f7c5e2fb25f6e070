//! Seeded random scenes and rays for the backend suite: the scene kinds lamina has
//! (triangle meshes, alpha-masked leaf cards, instances with rotation, non-uniform scale
//! and mirrors, quad and sphere lights). Every mesh has its own material, so a hit's
//! material names the mesh it is on. Everything is deterministic: a fixed seed, our own
//! generator.

use crate::accel::Ray;
use crate::tests::scenes::{camera_at, diffuse, film};
use glam::{Affine3A, Quat, Vec2, Vec3, Vec4};
use lamina_core::{AlphaMask, ColorInput, Instance, Light, Material, Mesh, Prototype, Scene};
use lamina_leaf::{LeafMaps, LeafMaterial, LeafParams, Texture, Wrap};
use std::sync::Arc;

/// A small deterministic generator (SplitMix64).
pub(super) struct Rng(u64);

impl Rng {
    pub(super) fn new(seed: u64) -> Self {
        Rng(seed)
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub(super) fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `[lo, hi)`.
    pub(super) fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    /// Uniform in `0..n`.
    pub(super) fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    pub(super) fn vec3(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }

    /// A uniformly distributed unit vector.
    pub(super) fn unit(&mut self) -> Vec3 {
        lamina_leaf::sampling::uniform_sphere(Vec2::new(self.f32(), self.f32()))
    }
}

/// Half the side of the cube `[-EXTENT, EXTENT]³` the random geometry lies in (m).
pub(super) const EXTENT: f32 = 2.0;

/// `n` rays over the scene cube: origins in a cube 1.5 times larger, half of them aimed at
/// a point of the cube and half in uniform directions; a quarter have a finite `tmax`.
pub(super) fn random_rays(rng: &mut Rng, n: usize) -> Vec<Ray> {
    (0..n)
        .map(|_| {
            let origin = rng.vec3(-1.5 * EXTENT, 1.5 * EXTENT);
            let dir = if rng.f32() < 0.5 {
                (rng.vec3(-EXTENT, EXTENT) - origin).normalize()
            } else {
                rng.unit()
            };
            let tmax = if rng.f32() < 0.25 {
                rng.range(0.1, 3.0 * EXTENT)
            } else {
                f32::INFINITY
            };
            Ray { origin, dir, tmax }
        })
        .collect()
}

/// A scene of the given meshes, materials, prototypes and instances, with no lights.
pub(super) fn scene(materials: Vec<Material>, meshes: Vec<Mesh>) -> Scene {
    Scene {
        radiometry: Default::default(),
        camera: camera_at(5.0, 40.0),
        film: film(4, 4, 1),
        integrator: lamina_core::Integrator::Path {
            max_depth: 1,
            rr_depth: 1,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: Vec::new(),
        sky: None,
        materials,
        meshes,
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// An opaque diffuse material.
pub(super) fn plain() -> Material {
    diffuse(0.5)
}

/// A diffuse material with an alpha matte.
fn masked(map: Texture, use_alpha_channel: bool, cutoff: f32) -> Material {
    Material::Diffuse {
        name: "masked".into(),
        reflectance: ColorInput::Constant(Vec3::splat(0.5)),
        alpha: Some(AlphaMask {
            map,
            use_alpha_channel,
            cutoff,
        }),
    }
}

/// A `w x h` texture of random grey values, alpha `1 - grey`.
fn random_texture(rng: &mut Rng, w: u32, h: u32, wrap: Wrap) -> Texture {
    let texels = (0..w * h)
        .map(|_| {
            let v = rng.f32();
            Vec4::new(v, v, v, 1.0 - v)
        })
        .collect();
    Texture::from_texels(w, h, texels, wrap)
}

/// The kinds of alpha test lamina has, one material each: none, a repeating matte (red
/// channel), a clamped one (alpha channel, another cutoff), and a leaf whose maps carry
/// an alpha map.
pub(super) fn alpha_materials(rng: &mut Rng) -> Vec<Material> {
    let leaf_maps = LeafMaps {
        front: Some(Texture::constant(Vec4::new(0.1, 0.3, 0.05, 1.0))),
        alpha: Some(random_texture(rng, 6, 9, Wrap::Clamp)),
        ..Default::default()
    };
    let leaf = Arc::new(LeafMaterial::new(leaf_maps, LeafParams::default()).unwrap());
    vec![
        plain(),
        masked(random_texture(rng, 4, 4, Wrap::Repeat), false, 0.5),
        masked(random_texture(rng, 7, 5, Wrap::Clamp), true, 0.3),
        Material::Leaf {
            name: "leaf".into(),
            leaf,
        },
    ]
}

/// A random triangle of side up to `size` near `centre`, UVs spread over `[-0.5, 1.5]²`.
fn random_triangle(rng: &mut Rng, centre: Vec3, size: f32, mesh: &mut Mesh) {
    let base = mesh.positions.len() as u32;
    for _ in 0..3 {
        mesh.positions.push(centre + rng.vec3(-size, size));
        mesh.uvs
            .push(Vec2::new(rng.range(-0.5, 1.5), rng.range(-0.5, 1.5)));
    }
    mesh.indices.push([base, base + 1, base + 2]);
}

/// A random card (parallelogram of two triangles, UVs over `[0, 1]²`) near `centre`. The
/// two triangles are split along either diagonal and listed in either order, so the build
/// sees every form of the pair a loader produces (merged into one parallelogram or not).
fn random_card(rng: &mut Rng, centre: Vec3, size: f32, mesh: &mut Mesh) {
    let (u, v) = (rng.unit() * rng.range(0.3, 1.0) * size, rng.unit() * size);
    let corner = centre - 0.5 * (u + v);
    let base = mesh.positions.len() as u32;
    mesh.positions
        .extend([corner, corner + u, corner + u + v, corner + v]);
    mesh.uvs.extend([Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]);
    let [a, b, c, d] = [base, base + 1, base + 2, base + 3];
    let mut tris = if rng.f32() < 0.5 {
        [[a, b, c], [a, c, d]]
    } else {
        [[a, b, d], [b, c, d]]
    };
    if rng.f32() < 0.3 {
        tris.swap(0, 1);
    }
    mesh.indices.extend(tris);
}

/// Random unit normals for every vertex of `mesh` (smooth triangles: a side table in the
/// BLAS, which must not change what a ray hits).
fn random_normals(rng: &mut Rng, mesh: &mut Mesh) {
    mesh.normals = mesh.positions.iter().map(|_| rng.unit()).collect();
}

/// Random triangles of all sizes in six meshes (one with vertex normals), two quad lights
/// (one two-sided) and two sphere lights.
pub(super) fn triangle_soup(rng: &mut Rng) -> Scene {
    let mut meshes = Vec::new();
    for k in 0..6 {
        let mut m = Mesh {
            material: k,
            ..Default::default()
        };
        for _ in 0..40 {
            let centre = rng.vec3(-EXTENT, EXTENT);
            let size = [0.05, 0.2, 0.6][rng.below(3)];
            random_triangle(rng, centre, size, &mut m);
        }
        if k == 0 {
            random_normals(rng, &mut m);
        }
        meshes.push(m);
    }
    let mut s = scene(vec![plain(); 6], meshes);
    s.lights = vec![
        Light::Quad {
            corner: Vec3::new(-1.0, 1.5, -1.0),
            edge_u: Vec3::new(1.5, 0.2, 0.0),
            edge_v: Vec3::new(0.0, 0.1, 1.2),
            radiance: Vec3::ONE,
            two_sided: false,
        },
        Light::Quad {
            corner: Vec3::new(0.5, -1.8, 0.3),
            edge_u: Vec3::new(0.0, 0.8, 0.0),
            edge_v: Vec3::new(0.7, 0.0, 0.3),
            radiance: Vec3::ONE,
            two_sided: true,
        },
        Light::Sphere {
            center: Vec3::new(1.2, 1.1, -0.4),
            radius: 0.3,
            radiance: Vec3::ONE,
        },
        Light::Sphere {
            center: Vec3::new(-1.4, -0.9, 1.0),
            radius: 0.15,
            radiance: Vec3::ONE,
        },
    ];
    s
}

/// Leaf cards: eight meshes of 25 random cards each, every alpha kind twice (material `k`
/// is alpha kind `k % 4` of [`alpha_materials`]).
pub(super) fn alpha_cards(rng: &mut Rng) -> Scene {
    let kinds = alpha_materials(rng);
    let mut meshes = Vec::new();
    for k in 0..8 {
        let mut m = Mesh {
            material: k,
            ..Default::default()
        };
        for _ in 0..25 {
            let centre = rng.vec3(-EXTENT, EXTENT);
            let size = rng.range(0.2, 0.9);
            random_card(rng, centre, size, &mut m);
        }
        meshes.push(m);
    }
    let materials = (0..8).map(|k| kinds[k % 4].clone()).collect();
    scene(materials, meshes)
}

/// A random placement: a random rotation, a non-uniform scale in `[0.4, 1.4]` mirrored
/// along one axis one time in three, a translation in the scene cube.
fn random_transform(rng: &mut Rng) -> Affine3A {
    let axis = rng.unit();
    let rotation = Quat::from_axis_angle(axis, rng.range(0.0, std::f32::consts::TAU));
    let mut scale = rng.vec3(0.4, 1.4);
    if rng.f32() < 1.0 / 3.0 {
        scale[rng.below(3)] *= -1.0;
    }
    Affine3A::from_scale_rotation_translation(scale, rotation, rng.vec3(-EXTENT, EXTENT))
}

/// Two levels: a cluster prototype (cards of every alpha kind and triangles with vertex
/// normals, enough for a BVH), a tiny one (one masked card and one triangle, tested
/// without a BVH), an unused one and an empty one, placed by 30 random transforms; world
/// cards and triangles beside them, a quad light and a sphere light.
pub(super) fn instanced(rng: &mut Rng) -> Scene {
    let kinds = alpha_materials(rng);
    // Materials: 0..4 the cluster's meshes, 4..6 the tiny prototype's, 6..8 the world's,
    // 8 the unused prototype's.
    let materials: Vec<Material> = [0, 1, 2, 3, 1, 0, 2, 0, 0]
        .iter()
        .map(|&k| kinds[k].clone())
        .collect();
    let mut cluster = Vec::new();
    for k in 0..4 {
        let mut m = Mesh {
            material: k,
            ..Default::default()
        };
        for _ in 0..6 {
            let centre = rng.vec3(-0.6, 0.6);
            if k == 0 {
                random_triangle(rng, centre, 0.3, &mut m);
            } else {
                random_card(rng, centre, 0.5, &mut m);
            }
        }
        if k == 0 {
            random_normals(rng, &mut m);
        }
        cluster.push(m);
    }
    let mut tiny_card = Mesh {
        material: 4,
        ..Default::default()
    };
    random_card(rng, Vec3::ZERO, 0.6, &mut tiny_card);
    let mut tiny_tri = Mesh {
        material: 5,
        ..Default::default()
    };
    random_triangle(rng, Vec3::new(0.1, 0.2, 0.0), 0.4, &mut tiny_tri);
    let mut world_cards = Mesh {
        material: 6,
        ..Default::default()
    };
    let mut world_tris = Mesh {
        material: 7,
        ..Default::default()
    };
    for _ in 0..15 {
        let c = rng.vec3(-EXTENT, EXTENT);
        random_card(rng, c, 0.7, &mut world_cards);
        let c = rng.vec3(-EXTENT, EXTENT);
        random_triangle(rng, c, 0.4, &mut world_tris);
    }
    let mut unused = Mesh {
        material: 8,
        ..Default::default()
    };
    random_card(rng, Vec3::ZERO, 1.0, &mut unused);
    let mut s = scene(materials, vec![world_cards, world_tris]);
    s.prototypes = vec![
        Prototype {
            name: "cluster".into(),
            meshes: cluster,
        },
        Prototype {
            name: "tiny".into(),
            meshes: vec![tiny_card, tiny_tri],
        },
        Prototype {
            name: "unused".into(),
            meshes: vec![unused],
        },
        Prototype {
            name: "empty".into(),
            meshes: Vec::new(),
        },
    ];
    s.instances = (0..30)
        .map(|i| Instance {
            prototype: [0, 1, 3][i % 3],
            transform: random_transform(rng),
        })
        .collect();
    s.lights = vec![
        Light::Quad {
            corner: Vec3::new(-0.5, 1.7, -0.5),
            edge_u: Vec3::new(1.0, 0.0, 0.1),
            edge_v: Vec3::new(0.0, 0.2, 1.0),
            radiance: Vec3::ONE,
            two_sided: false,
        },
        Light::Sphere {
            center: Vec3::new(-1.0, 1.0, 1.2),
            radius: 0.25,
            radiance: Vec3::ONE,
        },
    ];
    s
}

/// `scene` with every alpha matte removed (leaves keep their maps but lose the alpha map):
/// what the rays would hit if the mattes were ignored.
pub(super) fn without_mattes(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    for m in &mut s.materials {
        if matches!(m, Material::Leaf { .. }) || m.alpha_mask().is_some() {
            *m = plain();
        }
    }
    s
}
