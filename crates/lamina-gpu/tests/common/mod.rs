//! Shared by the agreement test and the `compare` example: the demo's leaf and scenes, and
//! one GPU-versus-offline comparison.
#![allow(dead_code)]

use glam::Vec2;
use lamina_gpu::{GpuContext, RenderSettings, metrics};
use lamina_render::{Image, RenderOptions};
use lamina_scene::Scene;
use lamina_scene::builtin::{self, BuiltinLeaf};
use std::sync::Arc;

/// The demo's leaf, made exactly as `lamina demo` makes it (crates/lamina-cli/src/demo.rs:
/// procedural beech, seed 1, 512x512 maps, adaxial roughness at least 0.35).
pub fn demo_leaf() -> BuiltinLeaf {
    let species: lamina_leafmaps::Species = "beech".parse().expect("built-in species");
    let spec = lamina_leafmaps::LeafSpec::new(species, 1, 512);
    let leaf = lamina_leafmaps::generate(&spec);
    let (w, h) = leaf.size_m;
    let params = lamina_leaf::LeafParams {
        roughness_adaxial: leaf.params.roughness_adaxial.max(0.35),
        ..leaf.params
    };
    let material = lamina_leaf::LeafMaterial::new(leaf.maps, params).expect("demo leaf");
    BuiltinLeaf {
        material: Arc::new(material),
        size_m: Vec2::new(w, h),
    }
}

/// The demo's three panels at `size x size`.
pub fn demo_scenes(size: u32, spp: u32) -> Vec<(&'static str, Scene)> {
    let leaf = demo_leaf();
    vec![
        (
            "front-lit leaf",
            builtin::leaf_front_lit(&leaf, (size, size), spp),
        ),
        (
            "back-lit leaf",
            builtin::leaf_back_lit(&leaf, (size, size), spp),
        ),
        ("bush", builtin::bush_scene(&leaf, (size, size), spp)),
    ]
}

/// One scene rendered both ways.
pub struct Comparison {
    pub gpu: Image,
    pub cpu: Image,
    /// Mean absolute error of the displayed (tone-mapped 8-bit sRGB) images, in [0, 1].
    pub mae: f64,
    /// Mean SSIM of the displayed images.
    pub ssim: f64,
    pub gpu_s: f64,
    pub cpu_s: f64,
}

/// Renders `scene` on the GPU and offline (`spp` samples, fixed seed) and compares them.
pub fn compare(ctx: &GpuContext, scene: &Scene, spp: u32) -> Comparison {
    let t = std::time::Instant::now();
    let (gpu, warnings) =
        lamina_gpu::render_scene(ctx, scene, RenderSettings::default()).expect("GPU render");
    // Only the expected note that lights other than the first sun cast no shadows.
    assert!(
        warnings
            .iter()
            .all(|w| w.contains("no shadows on the GPU path")),
        "{warnings:?}"
    );
    let gpu_s = t.elapsed().as_secs_f64();
    let t = std::time::Instant::now();
    let cpu = lamina_render::render(
        scene,
        &RenderOptions {
            spp: Some(spp),
            seed: 1,
            ..Default::default()
        },
    )
    .expect("offline render")
    .image;
    let cpu_s = t.elapsed().as_secs_f64();
    let a = lamina_render::output::to_srgb8(&gpu, &scene.film);
    let b = lamina_render::output::to_srgb8(&cpu, &scene.film);
    Comparison {
        mae: metrics::mean_abs_error(&a, &b),
        ssim: metrics::ssim(&a, &b, gpu.width as usize, gpu.height as usize),
        gpu,
        cpu,
        gpu_s,
        cpu_s,
    }
}

/// With `LAMINA_TEST_IMAGES=DIR`, writes the comparison's pair (GPU left) to `DIR/file`.
pub fn write_pair_if_asked(file: &str, c: &Comparison, film: &lamina_scene::Film) {
    if let Some(dir) = std::env::var_os("LAMINA_TEST_IMAGES") {
        let path = std::path::Path::new(&dir).join(file);
        lamina_render::write_image(&path, &side_by_side(&c.gpu, &c.cpu), film)
            .expect("write the comparison");
    }
}

/// `a` and `b` side by side with a 4-pixel black gap.
pub fn side_by_side(a: &Image, b: &Image) -> Image {
    let gap = 4;
    let width = a.width + gap + b.width;
    let height = a.height.max(b.height);
    let mut pixels = vec![glam::Vec3::ZERO; (width * height) as usize];
    for (img, x0) in [(a, 0), (b, a.width + gap)] {
        for y in 0..img.height {
            for x in 0..img.width {
                pixels[(y * width + x0 + x) as usize] = img.pixels[(y * img.width + x) as usize];
            }
        }
    }
    Image {
        width,
        height,
        pixels,
    }
}

/// A `size x size` view of one glTF-material square (0.8 m, filling the frame) facing the
/// camera 1 m away, under a sun from (0.15, 0.1, 1) whose mirror highlight lies right of
/// and above the centre, and a constant blue-grey sky. Nothing else: both renderers see
/// only direct sun and sky on the square. Exposure -1.5 stops keeps the gold highlight
/// below white (measured: brightest 8-bit value 230 of 255, GPU and offline).
pub fn pbr_square(material: lamina_scene::PbrMaterial, size: u32, spp: u32) -> Scene {
    use glam::Vec3;
    use lamina_scene::{Camera, Film, Integrator, Light, Material, Mesh, Sky};
    Scene {
        radiometry: Default::default(),
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 1.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 40.0,
            aperture_radius: 0.0,
            focus_distance: 1.0,
        },
        film: Film {
            exposure: -1.5,
            ..Film::new(size, size, spp)
        },
        integrator: Integrator::Path {
            max_depth: 8,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![Light::Sun {
            direction: Vec3::new(0.15, 0.1, 1.0).normalize(),
            irradiance: Vec3::splat(2.0),
            angular_diameter_deg: 0.53,
        }],
        sky: Some(Sky::Constant(Vec3::new(0.10, 0.13, 0.18))),
        materials: vec![Material::Pbr(Box::new(material))],
        meshes: vec![Mesh::quad(
            Vec3::new(-0.4, -0.4, 0.0),
            Vec3::new(0.8, 0.0, 0.0),
            Vec3::new(0.0, 0.8, 0.0),
            0,
        )],
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// A 64x64 tangent-space normal map of crossed ripples, `n ∝ (0.6 sin 6πu, 0.6 sin 4πv, 1)`
/// (lamina `v` up), so that both the `u` and the `v` axis of the frame show.
pub fn ripple_normal_map() -> lamina_scene::NormalMap {
    use glam::{Vec3, Vec4};
    let n = 64;
    let texels = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32, (i / n) as f32);
            let u = (x + 0.5) / n as f32;
            let v = 1.0 - (y + 0.5) / n as f32;
            let t = std::f32::consts::TAU;
            let m = Vec3::new(0.6 * (3.0 * t * u).sin(), 0.6 * (2.0 * t * v).sin(), 1.0);
            let c = m.normalize() * 0.5 + Vec3::splat(0.5);
            Vec4::new(c.x, c.y, c.z, 1.0)
        })
        .collect();
    lamina_scene::NormalMap {
        map: lamina_leaf::Texture::from_texels(n, n, texels, lamina_leaf::Wrap::Repeat),
        scale: 1.0,
    }
}
