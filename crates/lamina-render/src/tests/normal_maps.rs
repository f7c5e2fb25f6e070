//! Normal maps: the tangent frame's conventions (u, image up, mirrored UVs, vertex tangents,
//! mirroring instances) and the rendered result against the same tilt given as vertex
//! normals.

use super::scenes::{camera_at, card, film, opts, sun};
use crate::accel::{Accel, HitKind, Ray};
use crate::shading::shading_normal;
use crate::{Image, render};
use glam::{Affine3A, Vec3, Vec4};
use lamina_core::{
    Instance, Integrator, Material, Mesh, NormalMap, PbrMaterial, Prototype, Scene, Sky,
};
use lamina_leaf::{Texture, Wrap};

/// A constant normal map whose texels decode to the unit tangent-space vector `m`.
fn constant_map(m: Vec3) -> NormalMap {
    let rgb = m.normalize() * 0.5 + Vec3::splat(0.5);
    NormalMap {
        map: Texture::from_texels(1, 1, vec![rgb.extend(1.0)], Wrap::Repeat),
        scale: 1.0,
    }
}

fn pbr(normal_map: Option<NormalMap>) -> Material {
    let mut p = PbrMaterial::uniform("p", Vec3::splat(0.6), 0.0, 0.4);
    p.normal_map = normal_map;
    Material::Pbr(Box::new(p))
}

fn scene(meshes: Vec<Mesh>, material: Material) -> Scene {
    Scene {
        radiometry: Default::default(),
        camera: camera_at(3.0, 40.0),
        film: film(16, 16, 4),
        integrator: Integrator::Path {
            max_depth: 4,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![sun(Vec3::new(0.3, 0.5, 1.0).normalize(), 3.0)],
        sky: Some(Sky::Constant(Vec3::splat(0.2))),
        materials: vec![material],
        meshes,
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// The world shading normal where a ray from `(x, y, 3)` straight down `-z` hits.
fn normal_at(scene: &Scene, x: f32, y: f32) -> Vec3 {
    let accel = Accel::build(scene).unwrap();
    let ray = Ray {
        origin: Vec3::new(x, y, 3.0),
        dir: -Vec3::Z,
        tmax: f32::INFINITY,
    };
    let hit = accel.intersect(&ray).expect("the ray hits the card");
    let HitKind::Triangle { prim, bary } = hit.kind else {
        panic!("not a triangle");
    };
    let (_, info) = accel.surface(prim, bary);
    let m = scene.materials[0].normal_map();
    shading_normal(&accel, prim, bary, &info, m).expect("a normal map gives a shading normal")
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

/// Map `+x` tilts towards increasing `u`, map `+y` towards increasing `v` (the top of the
/// image), map `+z` is the surface normal; mirrored UVs, a mirroring instance and vertex
/// tangents keep those meanings.
#[test]
fn normal_map_axes_follow_u_and_image_up() {
    let (s, c) = (0.5f32, 0.75f32.sqrt()); // 30° tilt
    let along_x = Vec3::new(s, 0.0, c);
    let along_y = Vec3::new(0.0, s, c);
    // card(): u along +x, v along +y, front +z.
    for (m, want) in [
        (along_x, Vec3::new(s, 0.0, c)),
        (along_y, Vec3::new(0.0, s, c)),
        (Vec3::Z, Vec3::Z),
    ] {
        let got = normal_at(
            &scene(vec![card(1.0, 0.0, 0)], pbr(Some(constant_map(m)))),
            0.2,
            0.1,
        );
        assert!(close(got, want), "map {m}: {got}, want {want}");
    }
    // u mirrored (u along -x): map +x now tilts towards -x; +y still towards +y.
    let mut mirrored = card(1.0, 0.0, 0);
    for uv in &mut mirrored.uvs {
        uv.x = 1.0 - uv.x;
    }
    let sc = |m| scene(vec![mirrored.clone()], pbr(Some(constant_map(m))));
    assert!(close(
        normal_at(&sc(along_x), 0.2, 0.1),
        Vec3::new(-s, 0.0, c)
    ));
    assert!(close(
        normal_at(&sc(along_y), 0.2, 0.1),
        Vec3::new(0.0, s, c)
    ));
    // v mirrored: +y tilts towards -y.
    let mut flipped_v = card(1.0, 0.0, 0);
    for uv in &mut flipped_v.uvs {
        uv.y = 1.0 - uv.y;
    }
    let sc = |m| scene(vec![flipped_v.clone()], pbr(Some(constant_map(m))));
    assert!(close(
        normal_at(&sc(along_x), 0.2, 0.1),
        Vec3::new(s, 0.0, c)
    ));
    assert!(close(
        normal_at(&sc(along_y), 0.2, 0.1),
        Vec3::new(0.0, -s, c)
    ));
}

/// A card placed by a mirroring instance gets the same normal-mapped normal as the card
/// mirrored into world space (winding reversed, as the loaders do), in both map axes.
#[test]
fn mirroring_instance_matches_flattened_mirror() {
    let (s, c) = (0.5f32, 0.75f32.sqrt());
    let mirror = Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    for m in [Vec3::new(s, 0.0, c), Vec3::new(0.0, s, c)] {
        let material = pbr(Some(constant_map(m)));
        let mut inst = scene(Vec::new(), material.clone());
        inst.prototypes = vec![Prototype {
            name: "card".into(),
            meshes: vec![card(1.0, 0.0, 0)],
        }];
        inst.instances = vec![Instance {
            prototype: 0,
            transform: mirror,
        }];
        let mut flat = card(1.0, 0.0, 0);
        for p in &mut flat.positions {
            p.x = -p.x;
        }
        for t in &mut flat.indices {
            t.swap(1, 2);
        }
        let a = normal_at(&inst, 0.2, 0.1);
        let b = normal_at(&scene(vec![flat], material), 0.2, 0.1);
        assert!(close(a, b), "map {m}: instance {a} vs flattened {b}");
        // u runs along -x in world after the mirror.
        let want = if m.x > 0.0 {
            Vec3::new(-s, 0.0, c)
        } else {
            Vec3::new(0.0, s, c)
        };
        assert!(close(a, want), "map {m}: {a}, want {want}");
    }
}

/// Vertex tangents replace the UV tangent where the mesh has them (smooth triangles): a
/// tangent along `+y` turns a map `+x` tilt towards `+y`, and `w = -1` flips the bitangent.
#[test]
fn vertex_tangents_are_used() {
    let (s, c) = (0.5f32, 0.75f32.sqrt());
    // Slightly curved normals so the triangles are smooth (stored with their tangents).
    let mut mesh = card(1.0, 0.0, 0);
    mesh.normals = mesh
        .positions
        .iter()
        .map(|p| Vec3::new(p.x * 0.02, 0.0, 1.0).normalize())
        .collect();
    let with = |t: Vec4, m: Vec3| {
        let mut mesh = mesh.clone();
        mesh.tangents = vec![t; 4];
        normal_at(&scene(vec![mesh], pbr(Some(constant_map(m)))), 0.0, 0.1)
    };
    // Without tangents: UV frame; with a tangent along +x, w = +1: the same.
    let uv_frame = normal_at(
        &scene(
            vec![mesh.clone()],
            pbr(Some(constant_map(Vec3::new(s, 0.0, c)))),
        ),
        0.0,
        0.1,
    );
    let same = with(Vec4::new(1.0, 0.0, 0.0, 1.0), Vec3::new(s, 0.0, c));
    assert!(close(uv_frame, same), "{uv_frame} vs {same}");
    // Tangent along +y: map +x tilts towards +y; its bitangent n × t = -x.
    let t_y = with(Vec4::new(0.0, 1.0, 0.0, 1.0), Vec3::new(s, 0.0, c));
    assert!((t_y - Vec3::new(0.0, s, c)).length() < 0.02, "{t_y}");
    let b = with(Vec4::new(0.0, 1.0, 0.0, 1.0), Vec3::new(0.0, s, c));
    assert!((b - Vec3::new(-s, 0.0, c)).length() < 0.02, "{b}");
    let b_flipped = with(Vec4::new(0.0, 1.0, 0.0, -1.0), Vec3::new(0.0, s, c));
    assert!(
        (b_flipped - Vec3::new(s, 0.0, c)).length() < 0.02,
        "{b_flipped}"
    );
}

/// A constant normal map renders (path and paper integrators, sun + sky, glossy Pbr) like
/// the same tilt given as vertex normals: the same shading frame by two routes, so the
/// images agree to float rounding. A zero-strength map (`scale = 0`) renders exactly like
/// no map at all.
#[test]
fn constant_normal_map_renders_like_tilted_vertex_normals() {
    let tilt = Vec3::new(0.35, -0.2, 0.9).normalize();
    let integrators = [
        Integrator::Path {
            max_depth: 4,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        Integrator::Paper { ambient: None },
    ];
    for integrator in integrators {
        let mut mapped = scene(vec![card(1.0, 0.0, 0)], pbr(Some(constant_map(tilt))));
        mapped.integrator = integrator;
        mapped.film = film(24, 24, 16);
        let mut smooth = mapped.clone();
        smooth.materials = vec![pbr(None)];
        // The map's frame on this card is (x, y, z): vertex normals along `tilt` itself.
        smooth.meshes[0].normals = vec![tilt; 4];
        let a = render(&mapped, &opts(16, 2)).unwrap().image;
        let b = render(&smooth, &opts(16, 2)).unwrap().image;
        let diff = max_diff(&a, &b);
        let mean = a.mean();
        eprintln!("{integrator:?}: mapped mean {mean}, max difference {diff}");
        assert!(mean.min_element() > 0.01, "lit: {mean}");
        assert!(diff < 1e-4 * mean.max_element().max(1.0), "{diff}");
        // Different from the untilted card.
        let mut flat = mapped.clone();
        flat.materials = vec![pbr(None)];
        let f = render(&flat, &opts(16, 2)).unwrap().image;
        assert!(max_diff(&a, &f) > 0.01, "the tilt changes the image");
        // Strength zero: identical to no map.
        let mut zero = constant_map(tilt);
        zero.scale = 0.0;
        let mut z = mapped.clone();
        z.materials = vec![pbr(Some(zero))];
        let zi = render(&z, &opts(16, 2)).unwrap().image;
        assert!(max_diff(&zi, &f) < 1e-5, "scale 0 = no map");
    }
}

fn max_diff(a: &Image, b: &Image) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f32::max)
}

/// White furnace with glossy `pbr` surfaces (two cards facing each other at an angle, so
/// light bounces between them, under a constant white sky): a white dielectric conserves
/// energy (its diffuse part takes what the specular lobe leaves), so every pixel is 1; a
/// white metal only loses the single-scattering GGX deficit (a few % at roughness 0.5). A
/// normal map never adds energy; it loses what the side rules drop (directions on
/// different sides of the geometric and the shading normal: at most `(1 - cos α) / 2` per
/// bounce for a normal tilted by α, here α ≤ 29°, ~1.5 % measured).
#[test]
fn pbr_furnace() {
    let mut tilted = card(0.6, 0.0, 0);
    for p in &mut tilted.positions {
        *p = Vec3::new(p.x, p.y * 0.6, p.z + p.y * 0.8 + 0.3);
    }
    let ripple = {
        let texels = (0..16 * 16)
            .map(|i| {
                let (x, y) = ((i % 16) as f32, (i / 16) as f32);
                let m = Vec3::new((x * 0.8).sin() * 0.4, (y * 0.8).cos() * 0.4, 1.0).normalize();
                (m * 0.5 + Vec3::splat(0.5)).extend(1.0)
            })
            .collect();
        NormalMap {
            map: Texture::from_texels(16, 16, texels, Wrap::Repeat),
            scale: 1.0,
        }
    };
    let cases = [
        ("white dielectric", 0.0, None, 0.997, 1.003),
        (
            "white dielectric, normal-mapped",
            0.0,
            Some(ripple.clone()),
            0.95,
            1.003,
        ),
        ("white metal", 1.0, None, 0.94, 1.003),
    ];
    for (what, metallic, normal_map, lo, hi) in cases {
        let mut p = PbrMaterial::uniform("w", Vec3::ONE, metallic, 0.5);
        p.normal_map = normal_map;
        let scene = Scene {
            radiometry: Default::default(),
            camera: camera_at(2.5, 50.0),
            film: film(16, 16, 256),
            integrator: Integrator::Path {
                max_depth: 100,
                rr_depth: 100,
                light_sampling: Default::default(),
                sky_sampling: Default::default(),
            },
            lights: vec![],
            sky: Some(Sky::Constant(Vec3::ONE)),
            materials: vec![Material::Pbr(Box::new(p))],
            meshes: vec![card(0.8, -0.3, 0), tilted.clone()],
            prototypes: Vec::new(),
            instances: Vec::new(),
        };
        let m = render(&scene, &opts(256, 2)).unwrap().image.mean();
        eprintln!("{what}: furnace mean {m}");
        assert!(
            m.min_element() > lo && m.max_element() < hi,
            "{what}: image mean {m}, want [{lo}, {hi}]"
        );
    }
}
