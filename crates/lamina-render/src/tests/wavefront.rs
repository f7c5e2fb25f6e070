//! The wavefront path tracer (`integrators::wave`) against the one-path path tracer: the
//! scenes it serves render to the same sums bit for bit, with the same ray count, whatever
//! the geometry (mattes, instances, a periodic domain, vertex normals), lights, sky,
//! camera, filter, sample range and crop; the scenes it does not serve are left to the
//! one-path loop.

use super::scenes::*;
use crate::accel::Backend;
use crate::integrators::SceneContext;
use crate::integrators::wave::Wave;
use crate::{Crop, RenderOptions, SampleRange, render};
use glam::{Vec2, Vec3, Vec4};
use lamina_core::radiometry::{Periodic, Rect};
use lamina_core::{
    AlphaMask, ColorInput, Integrator, Light, LightSampling, Material, NormalMap, PbrMaterial,
    PixelFilter, Scene, Sky, SkySampling,
};
use lamina_leaf::{Texture, Wrap};

fn served(scene: &Scene) -> bool {
    let ctx = SceneContext::new(scene, Backend::default()).unwrap();
    Wave::new(&ctx).is_some()
}

/// Renders `scene` both ways with `o` and asserts equal sums (bit for bit) and rays. (On a
/// CPU without AVX2 + FMA renders never take the wave, and both ways are the one-path
/// loop.)
fn same_both_ways(what: &str, scene: &Scene, o: &RenderOptions) {
    assert!(served(scene), "{what}: the wave should serve this scene");
    let keep = RenderOptions {
        keep_sums: true,
        ..o.clone()
    };
    let wave = render(scene, &keep).unwrap();
    let one = render(
        scene,
        &RenderOptions {
            one_path_at_a_time: true,
            ..keep
        },
    )
    .unwrap();
    let (a, b) = (wave.sums.unwrap(), one.sums.unwrap());
    assert_eq!(a.len(), b.len(), "{what}");
    let differing = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| x.to_array().map(f64::to_bits) != y.to_array().map(f64::to_bits))
        .count();
    assert_eq!(
        differing,
        0,
        "{what}: {differing} of {} pixels differ",
        a.len()
    );
    assert_eq!(wave.stats.rays, one.stats.rays, "{what}: rays");
    assert!(
        a.iter().any(|s| s.max_element() > 0.0),
        "{what}: a black image proves little"
    );
}

/// A leaf material with all seven maps varying over the leaf (a bump map included), its
/// alpha map opaque (the cards' outlines are not what is tested here).
fn mapped_leaf() -> Material {
    use lamina_leaf::{LeafMaps, LeafMaterial, LeafParams};
    let map = |f: &dyn Fn(f32, f32) -> Vec4| {
        let (w, h) = (12, 10);
        let texels = (0..w * h)
            .map(|i| f((i % w) as f32 / w as f32, (i / w) as f32 / h as f32))
            .collect();
        Some(Texture::from_texels(w, h, texels, Wrap::Repeat))
    };
    let maps = LeafMaps {
        front: map(&|u, v| Vec4::new(0.05 + 0.1 * u, 0.3 - 0.1 * v, 0.04, 1.0)),
        back: map(&|u, _| Vec4::new(0.2, 0.3 + 0.1 * u, 0.15, 1.0)),
        translucency: map(&|u, v| Vec4::new(0.1 * u, 0.4, 0.05 + 0.05 * v, 1.0)),
        alpha: map(&|_, _| Vec4::ONE),
        thickness: map(&|u, v| Vec4::splat(0.4 + 0.3 * (9.0 * u).sin() * v)),
        extinction: map(&|u, v| Vec4::splat(0.5 + 0.3 * (7.0 * v).sin() * u)),
        bump: map(&|u, v| Vec4::splat(0.5 + 0.4 * (11.0 * u).sin() * (8.0 * v).cos())),
    };
    let params = LeafParams {
        bump_scale: 0.02,
        ..Default::default()
    };
    Material::Leaf {
        name: "mapped leaf".into(),
        leaf: std::sync::Arc::new(LeafMaterial::new(maps, params).unwrap()),
    }
}

/// The path integrator with these settings.
fn path_with(
    max_depth: u32,
    rr_depth: u32,
    light_sampling: LightSampling,
    sky_sampling: SkySampling,
) -> Integrator {
    Integrator::Path {
        max_depth,
        rr_depth,
        light_sampling,
        sky_sampling,
    }
}

fn path(scene: &mut Scene, max_depth: u32, rr_depth: u32) {
    scene.integrator = path_with(max_depth, rr_depth, LightSampling::All, Default::default());
}

#[test]
fn wavefront_is_path_bit_for_bit() {
    // The small canopy: a finite sun, a quad, a sphere and a point light, a constant sky
    // left to BSDF samples, a Gaussian filter, both served materials. 21 spp, progressive:
    // passes of 1, 1, 2, 4, 8 and 5 samples, so waves of every fill; and in passes of 16
    // and 5.
    let base = small_canopy_scene();
    let progressive = |o: RenderOptions| RenderOptions {
        progressive: true,
        ..o
    };
    same_both_ways("canopy", &base, &progressive(opts(21, 2)));
    same_both_ways("canopy, passes of 16", &base, &opts(21, 2));
    // An odd image size and 7 spp (passes of 1, 1, 2 and 3): the first passes' waves hold
    // several pixels, some pixels' samples span two waves, and tiles end in partly filled
    // waves.
    let mut s = base.clone();
    s.film.width = 37;
    s.film.height = 23;
    same_both_ways("37 x 23 pixels, 7 spp", &s, &progressive(opts(7, 2)));
    same_both_ways(
        "canopy, another seed, one thread",
        &base,
        &RenderOptions {
            seed: 12345,
            ..opts(40, 1)
        },
    );
    // Deep paths, roulette from the first bounce, and a depth limit of one and zero.
    for (d, rr) in [(12, 1), (1, 5), (0, 5)] {
        let mut s = base.clone();
        path(&mut s, d, rr);
        same_both_ways(&format!("max_depth {d}, rr_depth {rr}"), &s, &opts(9, 2));
    }
    // A thin lens and a box filter; a delta sun only.
    let mut s = base.clone();
    s.camera.aperture_radius = 0.05;
    s.camera.focus_distance = 2.5;
    s.film.filter = PixelFilter::Box;
    s.lights = vec![sun(Vec3::new(0.3, 1.0, 0.5), 400.0)];
    same_both_ways("lens, box filter, delta sun", &s, &opts(16, 2));
    // A sun wide enough for escaping BSDF rays to see its disc often (the wave adds
    // only the lights an escaping ray can see), beside a delta sun that no ray sees.
    let mut s = base.clone();
    s.lights = vec![
        Light::Sun {
            direction: Vec3::new(-0.2, 1.0, 0.4),
            irradiance: Vec3::splat(3.0),
            angular_diameter_deg: 40.0,
        },
        sun(Vec3::new(0.3, 1.0, 0.5), 2.0),
    ];
    same_both_ways("a wide sun and a delta sun", &s, &opts(12, 2));
    // The sky sampled by next-event estimation too, and an image sky.
    let mut s = base.clone();
    s.integrator = path_with(5, 2, LightSampling::All, SkySampling::Light);
    same_both_ways("sky sampled", &s, &opts(8, 2));
    // The constant sky drawn among the lights, one per vertex: what an escaping ray adds
    // is weighed with the sky's pick probability (the wave adds a constant sky in lanes).
    let mut one = s.clone();
    one.integrator = path_with(6, 2, LightSampling::One, SkySampling::Light);
    same_both_ways("one light drawn, constant sky sampled", &one, &opts(9, 2));
    let tex = Texture::from_texels(
        8,
        4,
        (0..32)
            .map(|i| Vec4::new(0.2 + 0.05 * (i % 5) as f32, 0.4, 0.6, 1.0))
            .collect(),
        Wrap::Repeat,
    );
    s.sky = Some(Sky::Image {
        map: tex,
        scale: 1.5,
        rotation_deg: 30.0,
        spectral: None,
    });
    same_both_ways("image sky", &s, &opts(8, 2));
    // One light per vertex drawn by power (`light_sampling = "one"`): the sun, the quad,
    // the sphere and the point light, and the image sky sampled by next-event estimation
    // too; then with the sky left to BSDF samples.
    for sky_sampling in [SkySampling::Light, SkySampling::default()] {
        s.integrator = path_with(6, 2, LightSampling::One, sky_sampling);
        same_both_ways(
            &format!("one light drawn, {sky_sampling:?}"),
            &s,
            &opts(11, 2),
        );
    }
    // Alpha-matted cards: the mattes act in the ray queries only.
    let mut s = base.clone();
    let matte = Texture::from_texels(
        2,
        2,
        vec![Vec4::ZERO, Vec4::ONE, Vec4::ONE, Vec4::ONE],
        Wrap::Clamp,
    );
    s.materials[0] = Material::DiffuseTransmission {
        name: "matted".into(),
        reflectance: ColorInput::Constant(Vec3::new(0.1, 0.3, 0.05)),
        transmittance: ColorInput::Constant(Vec3::new(0.1, 0.4, 0.05)),
        alpha: Some(AlphaMask {
            map: matte,
            use_alpha_channel: false,
            cutoff: 0.5,
        }),
    };
    same_both_ways("alpha mattes", &s, &opts(12, 2));
    // The mattes under two suns (a delta one and a 2° disc) and no sphere: the first
    // vertex's sun rays take lamina-accel's eight-ray grid queries (a sphere leaves every
    // ray to the one-ray query).
    s.lights = vec![
        sun(Vec3::new(0.3, 1.0, 0.5), 400.0),
        Light::Sun {
            direction: Vec3::new(-0.4, 0.8, 0.3),
            irradiance: Vec3::splat(200.0),
            angular_diameter_deg: 2.0,
        },
    ];
    same_both_ways("alpha mattes, two suns", &s, &opts(13, 2));
    // Colours from textures, looked up per hit: a textured reflectance and transmittance
    // (their luminance ratio, the lobe choice, varying over the card) and a textured
    // diffuse.
    let mut s = base.clone();
    let tex = |a: f32, b: f32| ColorInput::Texture {
        map: Texture::from_texels(
            4,
            4,
            (0..16)
                .map(|i| Vec4::new(a * (i % 4) as f32, b + 0.05 * (i / 4) as f32, 0.1, 1.0))
                .collect(),
            Wrap::Repeat,
        ),
        factor: Vec3::new(0.9, 0.8, 1.0),
    };
    s.materials[0] = Material::DiffuseTransmission {
        name: "textured leaf".into(),
        reflectance: tex(0.1, 0.2),
        transmittance: tex(0.05, 0.3),
        alpha: None,
    };
    s.materials[1] = Material::Diffuse {
        name: "textured".into(),
        reflectance: tex(0.2, 0.1),
        alpha: None,
    };
    same_both_ways("textured colours", &s, &opts(12, 2));
    // Materials the lane arithmetic does not serve, through their BSDFs lane by lane: a
    // leaf with all seven maps (bump included) beside a diffuse ground (both kinds of lane
    // in one wave), under "all" and "one", then beside a glTF-style pbr material with a
    // normal map (its frame's side checks) and diffuse transmission.
    let mut s = base.clone();
    s.materials[0] = mapped_leaf();
    same_both_ways("leaf material with maps", &s, &opts(12, 2));
    path(&mut s, 7, 1);
    same_both_ways("leaf material, deep paths", &s, &opts(9, 2));
    let mut s1 = s.clone();
    s1.integrator = path_with(6, 2, LightSampling::One, SkySampling::Light);
    same_both_ways("leaf material, one light drawn", &s1, &opts(9, 2));
    let tilted = NormalMap {
        map: Texture::from_texels(
            2,
            2,
            vec![
                Vec4::new(0.7, 0.5, 0.9, 1.0),
                Vec4::new(0.3, 0.6, 0.85, 1.0),
                Vec4::new(0.5, 0.2, 0.9, 1.0),
                Vec4::new(0.5, 0.5, 1.0, 1.0),
            ],
            Wrap::Repeat,
        ),
        scale: 1.0,
    };
    let mut p = PbrMaterial::uniform("pbr", Vec3::new(0.5, 0.6, 0.3), 0.3, 0.35);
    p.normal_map = Some(tilted);
    p.transmission = 0.4;
    s.materials[1] = Material::Pbr(Box::new(p));
    same_both_ways("leaf and pbr with a normal map", &s, &opts(9, 2));
    // Instances (rotated, scaled, mirrored).
    let (inst, _) = instanced_and_flat(&test_transforms());
    same_both_ways("instances", &inst, &opts(8, 2));
    // The same in a periodic domain (the ground spans the cell), seen from inside it.
    let mut periodic = inst.clone();
    periodic.radiometry.periodic = Some(Periodic {
        cell: Rect {
            min: Vec2::splat(-3.0),
            max: Vec2::splat(3.0),
        },
    });
    periodic.camera.position = Vec3::new(0.4, 0.3, 2.5);
    same_both_ways("periodic domain", &periodic, &opts(8, 2));
    // Vertex normals: smooth shading frames and their side checks.
    let sphere = sphere_scene(
        uv_sphere(Vec3::ZERO, 1.0, 12, 24, true, 1),
        vec![
            sun(Vec3::new(0.5, 0.8, 0.3), 300.0),
            Light::Point {
                position: Vec3::new(-1.5, 1.0, 2.0),
                intensity: Vec3::splat(4.0),
            },
        ],
        Some(Sky::Constant(Vec3::new(0.2, 0.3, 0.5))),
    );
    same_both_ways("smooth sphere", &sphere, &opts(16, 2));
    // A part of a split render: a sample range and a crop.
    same_both_ways(
        "samples 5..19 of 24, a crop",
        &base,
        &RenderOptions {
            samples: Some(SampleRange { start: 5, end: 19 }),
            crop: Some(Crop {
                x0: 7,
                y0: 3,
                x1: 31,
                y1: 22,
            }),
            ..opts(24, 2)
        },
    );
}

#[test]
fn wavefront_serves_rgb_path_renders() {
    let base = small_canopy_scene();
    assert!(served(&base));
    let one_light =
        |s: &mut Scene| s.integrator = path_with(5, 2, LightSampling::One, Default::default());
    let mut s = base.clone();
    one_light(&mut s);
    assert!(served(&s), "one light per vertex");
    // More lights than "all" samples in a wave: "all" leaves them to the one-path loop,
    // "one" draws one per lane.
    let mut s = base.clone();
    while s.lights.len() <= 8 {
        s.lights
            .push(sun(Vec3::new(0.1 * s.lights.len() as f32, 1.0, 0.2), 10.0));
    }
    assert!(!served(&s), "nine lights, all sampled");
    one_light(&mut s);
    assert!(served(&s), "nine lights, one drawn");
    let mut s = base.clone();
    s.integrator = Integrator::Paper { ambient: None };
    assert!(!served(&s), "the paper's integrator");
    let mut s = base.clone();
    s.materials[1] = Material::Diffuse {
        name: "textured".into(),
        reflectance: ColorInput::Texture {
            map: Texture::from_texels(1, 1, vec![Vec4::ONE], Wrap::Repeat),
            factor: Vec3::splat(0.5),
        },
        alpha: None,
    };
    assert!(served(&s), "a textured colour");
    let mut s = base;
    s.materials[0] = mapped_leaf();
    assert!(served(&s), "the leaf material (its BSDF lane by lane)");
}
