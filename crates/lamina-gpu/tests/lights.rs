//! Shadows of point, sphere and quad lights on the GPU path (their cubes of two-layer
//! translucent maps, `renderer/local_shadows.rs`) against the offline renderer. They run
//! on any Vulkan adapter, lavapipe included; without one they print a skip note, or fail
//! when `CI` is set.

mod common;

use glam::{Quat, Vec3};
use lamina_gpu::{ContextOptions, GpuContext, RenderSettings, Renderer, metrics};
use lamina_render::{Image, RenderOptions};
use lamina_scene::{Light, Scene};

fn context() -> Option<GpuContext> {
    lamina_gpu::context_for_tests(&ContextOptions::default())
        .expect("a Vulkan adapter (CI installs mesa-vulkan-drivers)")
}

/// The demo's leaf lying flat (adaxial side up) `0.75 h` above the studio ground (`h` the
/// leaf's length), seen obliquely from the front, lit by `lights` alone (no sky), which
/// stand above and behind it so that its shadow falls forward onto the ground.
fn flat_leaf_under(lights: Vec<Light>, size: u32) -> Scene {
    let (_, mut scene) = common::demo_scenes(size, 1).remove(0);
    let h = common::demo_leaf().size_m.y;
    let q = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let leaf = &mut scene.meshes[0];
    for p in &mut leaf.positions {
        *p = q * *p;
    }
    for n in &mut leaf.normals {
        *n = q * *n;
    }
    for t in &mut leaf.tangents {
        *t = (q * t.truncate()).extend(t.w);
    }
    scene.camera.position = Vec3::new(0.0, 1.1 * h, 1.5 * h);
    scene.camera.look_at = Vec3::new(0.0, -0.5 * h, 0.2 * h);
    scene.camera.focus_distance = (scene.camera.position - scene.camera.look_at).length();
    scene.camera.fov_deg = 50.0;
    scene.sky = None;
    scene.lights = lights;
    scene
}

/// Where the test lights stand (see [`flat_leaf_under`]), in units of the leaf's length.
const LIGHT_AT: Vec3 = Vec3::new(0.25, 1.5, -0.5);
/// Their intensity (W sr⁻¹) per h², the same for each kind.
const INTENSITY: f32 = 16.0;

/// The cases: a point light, a sphere light, a quad light (each alone) and a second sun (a
/// weak first sun from the front-left, the second from where the others stand).
fn lights(h: f32) -> Vec<(&'static str, Vec<Light>)> {
    let c = LIGHT_AT * h;
    let i = INTENSITY * h * h;
    let side = 0.5 * h;
    let r = 0.25 * h;
    let sun = |direction: Vec3, e: f32| Light::Sun {
        direction: direction.normalize(),
        irradiance: Vec3::splat(e),
        angular_diameter_deg: 0.53,
    };
    vec![
        (
            "point",
            vec![Light::Point {
                position: c,
                intensity: Vec3::splat(i),
            }],
        ),
        (
            "sphere",
            vec![Light::Sphere {
                center: c,
                radius: r,
                radiance: Vec3::splat(i / (std::f32::consts::PI * r * r)),
            }],
        ),
        (
            "quad",
            // Facing down (u x v = -y), its intensity toward the leaf about L A.
            vec![Light::Quad {
                corner: c - 0.5 * Vec3::new(side, 0.0, side),
                edge_u: Vec3::new(side, 0.0, 0.0),
                edge_v: Vec3::new(0.0, 0.0, side),
                radiance: Vec3::splat(i / (side * side)),
                two_sided: false,
            }],
        ),
        (
            "second-sun",
            vec![
                sun(Vec3::new(-0.6, 0.5, 0.6), 0.3),
                sun(LIGHT_AT, INTENSITY / LIGHT_AT.length_squared()),
            ],
        ),
    ]
}

fn mean(img: &Image, mask: &[bool]) -> f64 {
    let (s, n) = img
        .pixels
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .fold((0.0, 0usize), |(s, n), (p, _)| {
            (s + p.element_sum() as f64, n + 1)
        });
    s / n.max(1) as f64
}

/// `a`, `b` and `c` side by side (4-pixel gaps).
fn triple(a: &Image, b: &Image, c: &Image) -> Image {
    common::side_by_side(&common::side_by_side(a, b), c)
}

/// Each light's shadow on the GPU against the offline renderer (128x128, 256 spp), and
/// the same GPU frame without the light's shadow maps (`local_shadow_size = 0`, what the
/// GPU path drew before them):
///
/// * the whole image: MAE and SSIM of the displayed images;
/// * the shadow: the pixels the offline image shows at less than 60 % of the unshadowed
///   GPU frame (the leaf's shadow on the ground, and the shade under it), where the mean
///   radiance GPU / offline must be near 1: leaves pass 5-20 % of the light on, so the
///   shadow is neither black nor lit.
///
/// Measured on lavapipe (llvmpipe, Mesa 22.3.6), 2026-12-03:
///
/// | light                | MAE    | SSIM  | shadow GPU/offline | unshadowed: MAE, SSIM, shadow ratio |
/// |----------------------|--------|-------|--------------------|-------------------------------------|
/// | point                | 0.0045 | 0.980 | 0.961              | 0.0467, 0.793, 13.7                 |
/// | sphere (R = h/4)     | 0.0047 | 0.979 | 0.901              | 0.0438, 0.816, 5.47                 |
/// | quad (h/2 square)    | 0.0047 | 0.979 | 0.887              | 0.0405, 0.824, 5.28                 |
/// | second sun           | 0.0041 | 0.989 | 1.077              | 0.0347, 0.891, 12.1                 |
///
/// (The local lights' shadows cover 15-16 % of the image, the sun's 7 %. Their GPU
/// shadows are a little darker: the offline ones also hold light bounced between the
/// ground and the leaf's underside; the sun's edge is a little softer.) Bounds: the
/// shadow's ratio within 25 %, the MAE under 0.6 of the unshadowed frame's and the SSIM
/// above it (measured: 0.1x the MAE; without shadows the shadow is 5-14x too bright).
///
/// With `LAMINA_TEST_IMAGES=DIR` the triples (GPU, offline, GPU unshadowed) are written
/// there.
#[test]
fn local_light_shadows_agree_with_the_offline_renderer() {
    let Some(ctx) = context() else {
        return;
    };
    let h = common::demo_leaf().size_m.y;
    let size = 128;
    let spp = 256;
    for (name, light) in lights(h) {
        let scene = flat_leaf_under(light, size);
        let (gpu, warnings) =
            lamina_gpu::render_scene(&ctx, &scene, RenderSettings::default()).expect("GPU");
        assert!(warnings.is_empty(), "{name}: {warnings:?}");
        let off = RenderSettings {
            local_shadow_size: 0,
            ..Default::default()
        };
        let (flat, warnings) = lamina_gpu::render_scene(&ctx, &scene, off).expect("GPU");
        assert!(
            warnings.len() == 1
                && warnings[0].contains(&format!("light {} (", scene.lights.len()))
                && warnings[0].contains("no shadows"),
            "{name}: {warnings:?}"
        );
        let cpu = lamina_render::render(
            &scene,
            &RenderOptions {
                spp: Some(spp),
                seed: 1,
                ..Default::default()
            },
        )
        .expect("offline")
        .image;
        let shown = |img: &Image| lamina_render::output::to_srgb8(img, &scene.film);
        let (g8, c8, f8) = (shown(&gpu), shown(&cpu), shown(&flat));
        let (w, hh) = (size as usize, size as usize);
        let mae = metrics::mean_abs_error(&g8, &c8);
        let ssim = metrics::ssim(&g8, &c8, w, hh);
        let mae_flat = metrics::mean_abs_error(&f8, &c8);
        let ssim_flat = metrics::ssim(&f8, &c8, w, hh);
        let shadow: Vec<bool> = cpu
            .pixels
            .iter()
            .zip(&flat.pixels)
            .map(|(c, f)| f.element_sum() > 1e-4 && c.element_sum() < 0.6 * f.element_sum())
            .collect();
        let share = shadow.iter().filter(|m| **m).count() as f64 / shadow.len() as f64;
        let ratio = mean(&gpu, &shadow) / mean(&cpu, &shadow);
        let ratio_flat = mean(&flat, &shadow) / mean(&cpu, &shadow);
        let all = vec![true; shadow.len()];
        let whole = mean(&gpu, &all) / mean(&cpu, &all);
        eprintln!(
            "{name}: MAE {mae:.4} SSIM {ssim:.3}, mean GPU/offline {whole:.3}; shadow ({:.1} % \
             of the image) GPU/offline {ratio:.3}; unshadowed: MAE {mae_flat:.4} SSIM \
             {ssim_flat:.3}, shadow ratio {ratio_flat:.3}",
            100.0 * share
        );
        if let Some(dir) = std::env::var_os("LAMINA_TEST_IMAGES") {
            let path = std::path::Path::new(&dir).join(format!("{name}-shadow.png"));
            lamina_render::write_image(&path, &triple(&gpu, &cpu, &flat), &scene.film)
                .expect("write the triple");
        }
        assert!(
            share > 0.03,
            "{name}: the leaf casts a shadow in view ({share})"
        );
        assert!(
            ratio_flat > 1.8,
            "{name}: the shadow is dark offline ({ratio_flat})"
        );
        assert!(
            (ratio - 1.0).abs() < 0.25,
            "{name}: shadow GPU/offline {ratio}"
        );
        assert!(
            mae < 0.6 * mae_flat,
            "{name}: MAE {mae} vs unshadowed {mae_flat}"
        );
        assert!(
            ssim > ssim_flat,
            "{name}: SSIM {ssim} vs unshadowed {ssim_flat}"
        );
    }
}

/// Lights past the shadow maps the GPU path has cast no shadows and are named; a long quad's
/// shadow (drawn from the disc of its area) is named; shadowed lights are not.
#[test]
fn lights_without_shadow_maps_are_named() {
    let Some(ctx) = context() else {
        return;
    };
    let h = common::demo_leaf().size_m.y;
    let point = |k: usize| Light::Point {
        position: Vec3::new(0.1 * k as f32, 2.0, 0.0) * h,
        intensity: Vec3::splat(0.01),
    };
    let mut scene = flat_leaf_under(vec![point(0)], 32);
    scene.lights = (0..lamina_gpu::MAX_SHADOWED_LIGHTS + 2)
        .map(point)
        .collect();
    scene.lights.push(Light::Quad {
        corner: Vec3::new(0.0, 2.0 * h, 0.0),
        edge_u: Vec3::new(h, 0.0, 0.0),
        edge_v: Vec3::new(0.0, 0.0, 0.1 * h),
        radiance: Vec3::ONE,
        two_sided: true,
    });
    let r = Renderer::new(&ctx, &scene, RenderSettings::default()).expect("renderer");
    let w = r.warnings().join("\n");
    eprintln!("{w}");
    let n = lamina_gpu::MAX_SHADOWED_LIGHTS;
    assert!(
        w.contains(&format!(
            "light {} (point), light {} (point), light {} (quad) cast no shadows",
            n + 1,
            n + 2,
            n + 3
        )) && w.contains(&format!("it shadows the first sun and {n} other lights")),
        "{w}"
    );
    assert!(!w.contains("light 1 (point)"), "{w}");
    // The shadowed quad here is the ninth light when fewer are shadowed first.
    scene.lights.drain(1..n + 2);
    let r = Renderer::new(&ctx, &scene, RenderSettings::default()).expect("renderer");
    let w = r.warnings().join("\n");
    assert!(
        w.contains("light 2 (quad) is 10.0 times longer than wide") && !w.contains("no shadows"),
        "{w}"
    );
    assert_eq!(r.local_shadow_bytes(), 2 * 6 * 2 * 512 * 512 * 12);
}

/// Nine suns past the first: each takes 32 array layers (4x4 tiles, two layers each), so
/// eight fill the device's 256 layers and the ninth is named as casting no shadows; the
/// frame renders (small maps keep the memory low).
#[test]
fn many_suns_fill_the_array_layers_and_the_rest_are_named() {
    let Some(ctx) = context() else {
        return;
    };
    let sun = |k: usize| Light::Sun {
        direction: Vec3::new(0.1 * k as f32, 1.0, 0.3).normalize(),
        irradiance: Vec3::splat(0.2),
        angular_diameter_deg: 0.53,
    };
    let scene = flat_leaf_under((0..10).map(sun).collect(), 32);
    let settings = RenderSettings {
        local_shadow_size: 64,
        ..Default::default()
    };
    let mut r = Renderer::new(&ctx, &scene, settings).expect("renderer");
    let w = r.warnings().join("\n");
    eprintln!("{w}");
    assert!(
        w.contains("light 10 (sun) casts no shadows") && !w.contains("light 9 (sun)"),
        "{w}"
    );
    assert_eq!(r.local_shadow_bytes(), 256 * 64 * 64 * 12);
    let img = r.render_image().expect("frame");
    assert!(img.pixels.iter().any(|p| p.max_element() > 0.0));
}
