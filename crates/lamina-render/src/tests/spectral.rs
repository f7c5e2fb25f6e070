//! Spectral renders (`crate::spectral`): `spectral = "visible"` against RGB and the
//! furnace, bands in one pass against bands three at a time.

use super::integrators::furnace_scene;
use super::scenes::*;
use crate::{RenderOptions, render, render_bands};
use glam::Vec3;
use lamina_core::{ColorInput, Integrator, Light, Material, Mesh, Scene, Sky, SpectralMode};
use lamina_leaf::spectrum::bands::{Band, BandBasis};
use lamina_leaf::spectrum::difference::ciede2000_rgb;
use lamina_leaf::{LeafMaps, LeafMaterial, LeafParams, Pigments};
use std::sync::Arc;

fn visible(mut scene: Scene) -> Scene {
    scene.film.spectral = SpectralMode::Visible;
    scene
}

/// White surfaces in a white sky stay white through the bins: every wavelength is
/// energy-conserving, and RGB white emission is D65, whose CIE colour is white.
#[test]
fn visible_furnace_is_white() {
    let scene = visible(furnace_scene());
    let out = render(&scene, &opts(256, 2)).unwrap();
    let m = out.image.mean();
    assert!(
        (m - Vec3::ONE).abs().max_element() < 0.006,
        "image mean {m}"
    );
}

/// A card of colour `c` (Lambertian) filling its share of the view.
fn coloured(name: &str, c: Vec3) -> Material {
    Material::Diffuse {
        name: name.into(),
        reflectance: ColorInput::Constant(c),
        alpha: None,
    }
}

/// Six cards side by side: three saturated diffuse colours, a soil colour, an RGB leaf of
/// the layered model and a leaf made from PROSPECT pigments, over a grey floor, under a
/// warm sun and a blue constant sky.
fn colour_chart() -> Scene {
    let leaf = LeafMaterial::new(LeafMaps::default(), LeafParams::default()).unwrap();
    let pigment = LeafMaterial::from_parts(
        LeafMaps::default(),
        LeafParams::default(),
        Some(Pigments::default()),
    )
    .unwrap();
    let mut materials = vec![
        coloured("red", Vec3::new(0.7, 0.08, 0.05)),
        coloured("green", Vec3::new(0.1, 0.5, 0.08)),
        coloured("blue", Vec3::new(0.06, 0.1, 0.6)),
        coloured("soil", Vec3::new(0.25, 0.17, 0.1)),
        Material::Leaf {
            name: "leaf".into(),
            leaf: Arc::new(leaf),
        },
        Material::Leaf {
            name: "pigments".into(),
            leaf: Arc::new(pigment),
        },
    ];
    materials.push(coloured("floor", Vec3::splat(0.4)));
    let mut meshes: Vec<Mesh> = Vec::new();
    for k in 0..6u32 {
        let mut m = card(0.16, 0.0, k);
        let dx = -0.85 + 0.34 * k as f32;
        for p in &mut m.positions {
            p.x += dx;
        }
        meshes.push(m);
    }
    let mut floor = card(3.0, -0.3, 6);
    for p in &mut floor.positions {
        *p = Vec3::new(p.x, -0.25, p.y - 0.3);
    }
    floor.indices = vec![[0, 2, 1], [0, 3, 2]];
    meshes.push(floor);
    Scene {
        radiometry: Default::default(),
        camera: camera_at(2.2, 50.0),
        film: film(96, 64, 256),
        integrator: Integrator::Path {
            max_depth: 6,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![Light::Sun {
            direction: Vec3::new(0.3, 0.5, 1.0),
            irradiance: Vec3::new(3.0, 2.7, 2.3),
            angular_diameter_deg: 0.53,
        }],
        sky: Some(Sky::Constant(Vec3::new(0.25, 0.32, 0.45))),
        materials,
        meshes,
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// Means of `b x b` blocks of an image (noise averaged out before colours are compared).
fn blocks(img: &crate::Image, b: u32) -> Vec<Vec3> {
    let mut out = Vec::new();
    for by in 0..img.height / b {
        for bx in 0..img.width / b {
            let mut s = Vec3::ZERO;
            for y in by * b..(by + 1) * b {
                for x in bx * b..(bx + 1) * b {
                    s += img.pixels[(y * img.width + x) as usize];
                }
            }
            out.push(s / (b * b) as f32);
        }
    }
    out
}

/// The visible render of an RGB scene looks like its RGB render: mean CIEDE2000 over 8 x 8
/// pixel blocks below 2 (the bar; measured 0.16), every card's mean colour within 1
/// (measured at most 0.56: the saturated green, whose upsampled spectrum is broad, and the
/// pigment leaf, truly spectral in the visible render and RGB by its CIE colour in the RGB
/// one).
#[test]
fn visible_render_of_an_rgb_scene_matches_the_rgb_render() {
    let rgb_scene = colour_chart();
    let o = opts(256, 2);
    let rgb = render(&rgb_scene, &o).unwrap().image;
    let vis = render(&visible(colour_chart()), &o).unwrap().image;
    let white = Vec3::splat(rgb.pixels.iter().map(|p| p.y).fold(0.0, f32::max));
    // ΔE of radiances relative to the brightest green in the frame (the white of CIELAB).
    let de: Vec<f64> = blocks(&rgb, 8)
        .iter()
        .zip(blocks(&vis, 8))
        .map(|(a, b)| ciede2000_rgb(*a / white, b / white))
        .collect();
    let mean = de.iter().sum::<f64>() / de.len() as f64;
    let worst = de.iter().cloned().fold(0.0, f64::max);
    eprintln!(
        "visible vs RGB: mean ΔE00 {mean:.3} over {} blocks, worst {worst:.3}",
        de.len()
    );
    assert!(mean < 2.0, "mean ΔE00 {mean}");
    // Per card: the central 10 x 10 pixels of each.
    for k in 0..6u32 {
        let x0 = (96.0 * (0.5 + (-0.85 + 0.34 * k as f32) / (2.2 * 2.0 * 25f32.to_radians().tan())))
            as u32
            - 5;
        let mean_of = |img: &crate::Image| {
            let mut s = Vec3::ZERO;
            for y in 27..37 {
                for x in x0..x0 + 10 {
                    s += img.pixels[(y * 96 + x) as usize];
                }
            }
            s / 100.0
        };
        let (a, b) = (mean_of(&rgb), mean_of(&vis));
        let d = ciede2000_rgb(a / white, b / white);
        eprintln!("card {k}: RGB {a} visible {b} ΔE00 {d:.3}");
        assert!(d < 1.0, "card {k}: RGB {a} visible {b}: ΔE00 {d}");
    }
}

/// A light seen directly keeps its RGB colour through the bins (D65-shaped upsampling, CIE
/// observer): within 1 CIEDE2000.
#[test]
fn visible_emitters_keep_their_colour() {
    for c in [
        Vec3::new(0.9, 0.2, 0.05),
        Vec3::new(0.1, 0.8, 0.2),
        Vec3::new(0.2, 0.3, 1.0),
        Vec3::ONE,
    ] {
        let scene = Scene {
            radiometry: Default::default(),
            camera: camera_at(1.0, 30.0),
            film: film(8, 8, 64),
            integrator: Integrator::Path {
                max_depth: 2,
                rr_depth: 2,
                light_sampling: Default::default(),
                sky_sampling: Default::default(),
            },
            lights: vec![],
            sky: Some(Sky::Constant(c)),
            materials: vec![diffuse(0.5)],
            meshes: vec![],
            prototypes: Vec::new(),
            instances: Vec::new(),
        };
        let m = render(&visible(scene), &opts(64, 2)).unwrap().image.mean();
        let d = ciede2000_rgb(m / c.max_element(), c / c.max_element());
        assert!(d < 1.0, "{c}: visible {m}, ΔE00 {d}");
    }
}

/// The same seed gives the same visible image whatever the thread count; another seed
/// another one.
#[test]
fn visible_renders_are_deterministic() {
    let mut scene = visible(colour_chart());
    scene.film = film(24, 16, 8);
    scene.film.spectral = SpectralMode::Visible;
    let a = render(&scene, &opts(8, 1)).unwrap().image;
    let b = render(&scene, &opts(8, 2)).unwrap().image;
    assert_eq!(a.pixels, b.pixels);
    let c = render(
        &scene,
        &RenderOptions {
            seed: 8,
            ..opts(8, 2)
        },
    )
    .unwrap()
    .image;
    assert_ne!(a.pixels, c.pixels);
}

/// The paper integrator is RGB only: a visible render says so.
#[test]
fn visible_needs_the_path_integrator() {
    let mut scene = visible(furnace_scene());
    scene.integrator = Integrator::Paper { ambient: None };
    let e = render(&scene, &opts(1, 1)).unwrap_err().to_string();
    assert!(
        e.contains("path integrator") && e.contains("visible"),
        "{e}"
    );
}

fn bands(n: usize) -> Vec<Band> {
    (0..n)
        .map(|k| {
            let lo = 420.0 + 110.0 * k as f32;
            Band::flat(format!("b{k}"), lo, lo + 40.0)
        })
        .collect()
}

/// The furnace in every band of a render of 14 bands (five sets: two paths per sample of
/// four and one set): each band converges to the sky's band value.
#[test]
fn furnace_in_fourteen_bands_at_once() {
    let bands = bands(14);
    let out = render_bands(&furnace_scene(), &bands, &opts(128, 2)).unwrap();
    assert_eq!(out.planes.len(), 14);
    for (k, b) in bands.iter().enumerate() {
        let sky = BandBasis::new([b, b, b]).emission(Vec3::ONE).x;
        let mean =
            out.planes[k].iter().map(|&v| v as f64).sum::<f64>() / out.planes[k].len() as f64;
        assert!(
            (mean / sky as f64 - 1.0).abs() < 0.006,
            "band {k}: mean {mean} vs sky {sky}"
        );
    }
}

/// Bands in one pass (one path per sample for all sets) and bands three at a time (a whole
/// render per set, as the paper integrator does) estimate the same image: their means per
/// card agree within the noise of 256 samples.
#[test]
fn bands_in_one_pass_match_bands_three_at_a_time() {
    let bands = bands(5);
    let scene = colour_chart();
    let o = opts(256, 2);
    let one = render_bands(&scene, &bands, &o).unwrap();
    for (g, group) in crate::bands::band_groups(bands.len()).iter().enumerate() {
        let grouped = render(
            &crate::bands::group_scene(&scene, &bands, group).unwrap(),
            &o,
        )
        .unwrap()
        .image;
        let blocks_of = |plane: &[f32]| {
            let img = crate::Image {
                width: one.width,
                height: one.height,
                pixels: plane.iter().map(|&v| Vec3::splat(v)).collect(),
            };
            blocks(&img, 16)
                .into_iter()
                .map(|v| v.x)
                .collect::<Vec<_>>()
        };
        for (c, &b) in group.iter().enumerate() {
            let grouped_plane: Vec<f32> = grouped.pixels.iter().map(|p| p[c]).collect();
            let (x, y) = (blocks_of(&one.planes[b]), blocks_of(&grouped_plane));
            let scale = y.iter().cloned().fold(1e-6, f32::max);
            for (i, (p, q)) in x.iter().zip(&y).enumerate() {
                assert!(
                    (p - q).abs() < 0.03 * scale + 0.03 * q.abs(),
                    "group {g} band {b} block {i}: one pass {p}, grouped {q}"
                );
            }
        }
    }
}

/// Bands split by samples add up to the whole band render (parts for a cluster).
#[test]
fn band_parts_add_up_to_the_whole() {
    let bands = bands(4);
    let mut scene = colour_chart();
    scene.film = film(32, 16, 6);
    let whole = render_bands(
        &scene,
        &bands,
        &RenderOptions {
            keep_sums: true,
            ..opts(6, 2)
        },
    )
    .unwrap();
    let mut sums = vec![vec![0.0f64; 32 * 16]; 4];
    for k in 0..3 {
        let part = render_bands(
            &scene,
            &bands,
            &RenderOptions {
                keep_sums: true,
                samples: Some(crate::SampleRange::part(k, 3, 6)),
                ..opts(6, 2)
            },
        )
        .unwrap();
        for (s, p) in sums.iter_mut().zip(part.sums.unwrap()) {
            for (a, b) in s.iter_mut().zip(p) {
                *a += b;
            }
        }
    }
    assert_eq!(Some(sums), whole.sums);
}

/// A visible render split by samples adds up to the whole, bit for bit (its parts merge
/// like an RGB render's).
#[test]
fn visible_parts_add_up_to_the_whole() {
    let mut scene = visible(colour_chart());
    scene.film = film(24, 16, 6);
    scene.film.spectral = SpectralMode::Visible;
    let keep = |samples| RenderOptions {
        keep_sums: true,
        samples,
        ..opts(6, 2)
    };
    let whole = render(&scene, &keep(None)).unwrap().sums.unwrap();
    let mut sums = vec![glam::DVec3::ZERO; whole.len()];
    for k in 0..2 {
        let part = render(&scene, &keep(Some(crate::SampleRange::part(k, 2, 6))))
            .unwrap()
            .sums
            .unwrap();
        for (a, b) in sums.iter_mut().zip(part) {
            *a += b;
        }
    }
    assert_eq!(sums, whole);
}

/// `light_sampling = "one"` in a visible render (the spectral integrator draws the light
/// from the scene's own lights and weighs every channel set by the same probability): the
/// small canopy under five lights (the sky light-sampled) renders the same image mean as
/// with every light sampled, within 0.5 % per channel; and so does it with the sky left to
/// BSDF samples (`sky_sampling`'s default for this constant sky), every light or one.
#[test]
fn visible_one_light_per_vertex_keeps_the_image() {
    use lamina_core::{LightSampling, SkySampling};
    let scene = visible(small_canopy_scene());
    let with = |light_sampling, sky_sampling| {
        let mut s = scene.clone();
        s.integrator = Integrator::Path {
            max_depth: 6,
            rr_depth: 2,
            light_sampling,
            sky_sampling,
        };
        render(&s, &opts(512, 2)).unwrap()
    };
    let all = with(LightSampling::All, SkySampling::Light);
    let ma = all.image.mean();
    for (what, ls, sky) in [
        ("one", LightSampling::One, SkySampling::Light),
        ("sky by BSDF samples", LightSampling::All, SkySampling::Auto),
        (
            "one, sky by BSDF samples",
            LightSampling::One,
            SkySampling::Auto,
        ),
    ] {
        let other = with(ls, sky);
        let mo = other.image.mean();
        assert!(
            ((mo - ma) / ma).abs().max_element() < 0.005,
            "image means: {what} {mo} vs all {ma}"
        );
        assert!(other.stats.rays < all.stats.rays, "{what}: rays");
    }
}

/// A spectral path given its camera ray's first hit (the tile loop finds a pixel's camera
/// hits together, `Accel::intersect_many`, and a band render's chunks share them) is the
/// path that finds it itself: every set's radiance bit for bit, and the same ray count,
/// over the colour chart's camera rays (misses, diffuse cards, RGB and pigment leaves).
#[test]
fn spectral_paths_given_their_camera_hit_are_the_same() {
    use crate::accel::{Backend, Hit, Ray};
    use crate::integrators::SceneContext;
    use crate::integrators::spectral::radiance_sets;
    use crate::materials::SurfaceBsdf;
    use crate::sampler::PixelSampler;
    use glam::Vec2;
    use lamina_leaf::spectrum::bands::Illuminant;

    let scene = colour_chart();
    let b = bands(6);
    let groups = [[&b[0], &b[1], &b[2]], [&b[3], &b[4], &b[5]]];
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let sets = crate::spectral::build_sets(&scene, &groups, Illuminant::Solar, &pool).unwrap();
    let ctx = SceneContext::new(&scene, Backend::default())
        .unwrap()
        .with_sets(sets, vec![0, 1])
        .unwrap();
    let (w, h) = (scene.film.width, scene.film.height);
    let (mut hits, mut paths) = (0, 0);
    // Each path's vertex BSDFs written over the last path's (as a tile's samples do).
    let (mut b1, mut b2) = ([SurfaceBsdf::BLANK; 2], [SurfaceBsdf::BLANK; 2]);
    for y in (0..h).step_by(7) {
        for x in (0..w).step_by(5) {
            let film = Vec2::new(x as f32 + 0.37, y as f32 + 0.61);
            let (origin, dir) = ctx.camera.generate_ray(film, Vec2::splat(0.5));
            let ray = Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            };
            let mut found: [Option<Hit>; 1] = [None];
            ctx.accel.intersect_many(&[ray], &mut found);
            hits += usize::from(found[0].is_some());
            for i in 0..4 {
                let start = PixelSampler::new(11, x, y, i);
                let (mut s1, mut s2) = (start, start);
                let (mut r1, mut r2) = (0u64, 0u64);
                let a =
                    radiance_sets::<2>(&ctx, [0, 1], ray, None, &mut s1, 8, 2, &mut r1, &mut b1);
                let g = radiance_sets::<2>(
                    &ctx,
                    [0, 1],
                    ray,
                    Some(found[0]),
                    &mut s2,
                    8,
                    2,
                    &mut r2,
                    &mut b2,
                );
                let bits = |l: &[Vec3; 2]| l.map(|v| v.to_array().map(f32::to_bits));
                assert_eq!(bits(&a), bits(&g), "pixel ({x}, {y}) sample {i}");
                assert_eq!(r1, r2, "pixel ({x}, {y}) sample {i}: rays");
                paths += 1;
            }
        }
    }
    assert!(
        hits > 0 && hits < paths / 4,
        "{hits} of {} camera rays hit",
        paths / 4
    );
}
