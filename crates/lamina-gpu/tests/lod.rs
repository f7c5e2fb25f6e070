//! Level of detail and culling on the GPU path, on an instanced forest: what stochastic
//! simplification must keep (brightness, colour, coverage, agreement with the offline
//! renderer, stillness while the camera moves) and what culling must save. They run on
//! any Vulkan adapter, lavapipe included (CI installs mesa-vulkan-drivers).

mod common;

use glam::Vec3;
use lamina_gpu::metrics::{coverage, mean_abs_error, mean_radiance, ssim};
use lamina_gpu::{ContextOptions, FrameView, GpuContext, RenderSettings, Renderer};
use lamina_image::to_srgb8;
use lamina_scene::Scene;

fn context() -> Option<GpuContext> {
    lamina_gpu::context_for_tests(&ContextOptions::default())
        .expect("a Vulkan adapter (CI installs mesa-vulkan-drivers)")
}

/// 9 trees of 3000 leaves, 160x90.
fn forest() -> Scene {
    lamina_bench::frame_forest_scene(9, 3000, (160, 90)).expect("forest")
}

fn settings(lod_pixels: f32) -> RenderSettings {
    RenderSettings {
        lod_pixels,
        ..Default::default()
    }
}

fn sky(scene: &Scene) -> Vec3 {
    match scene.sky {
        Some(lamina_scene::Sky::Constant(c)) => c,
        _ => panic!("the forest has a constant sky"),
    }
}

/// A scene rendered at full detail and with LOD 1 px² (of the image: 4 of the 2x
/// supersampled target), and what LOD kept.
struct LodPair {
    full: lamina_image::Image,
    lod: lamina_image::Image,
    /// Camera-pass triangles at full detail and with LOD.
    tris: [u64; 2],
    /// Leaves (or leaf instances) LOD may thin out.
    leaves: u64,
}

/// Renders `scene` both ways and checks what LOD must keep: mean radiance per channel
/// within 2 %, leaf coverage (the scene without its world meshes, against the sky) within
/// 3 %, the displayed image within MAE 0.02 and SSIM 0.85.
fn lod_pair(ctx: &GpuContext, scene: &Scene, name: &str) -> LodPair {
    let bare = Scene {
        meshes: Vec::new(),
        ..scene.clone()
    };
    let mut full = Renderer::new(ctx, scene, settings(0.0)).expect("full detail");
    let mut lod = Renderer::new(ctx, scene, settings(1.0)).expect("with LOD");
    let a = full.render_image().expect("full");
    let b = lod.render_image().expect("lod");
    let [full_tris, _] = full.drawn_triangles().unwrap().expect("culling runs");
    let [lod_tris, lod_shadow] = lod.drawn_triangles().unwrap().expect("culling runs");
    let (ma, mb) = (mean_radiance(&a.pixels), mean_radiance(&b.pixels));
    let cov = |r: f32| {
        let (img, _) = lamina_gpu::render_scene(ctx, &bare, settings(r)).expect("bare");
        coverage(&img.pixels, sky(scene), 0.01)
    };
    let (ca, cb) = (cov(0.0), cov(1.0));
    let (sa, sb) = (to_srgb8(&a, &scene.film), to_srgb8(&b, &scene.film));
    let (w, h) = (a.width as usize, a.height as usize);
    let (mae, s) = (mean_abs_error(&sa, &sb), ssim(&sa, &sb, w, h));
    eprintln!(
        "{name}: triangles full {full_tris}, LOD {lod_tris} (shadow {lod_shadow}); mean radiance \
         full {ma:.4?}, LOD {mb:.4?}; coverage full {ca:.4}, LOD {cb:.4}; LOD vs full: MAE \
         {mae:.4}, SSIM {s:.4}"
    );
    if let Some(dir) = std::env::var_os("LAMINA_TEST_IMAGES") {
        let path = std::path::Path::new(&dir).join(format!("{}.png", name.replace(' ', "_")));
        lamina_render::write_image(&path, &common::side_by_side(&a, &b), &scene.film)
            .expect("write");
    }
    for k in 0..3 {
        let rel = (mb[k] / ma[k] - 1.0).abs();
        assert!(rel < 0.02, "{name} channel {k}: {} vs {}", mb[k], ma[k]);
    }
    assert!(
        (cb / ca - 1.0).abs() < 0.03,
        "{name}: coverage {cb} vs {ca}"
    );
    assert!(mae < 0.02 && s > 0.85, "{name}: MAE {mae}, SSIM {s}");
    LodPair {
        leaves: lod.lod_leaves(),
        full: a,
        lod: b,
        tris: [full_tris, lod_tris],
    }
}

/// The forest of leaf cards (leaves thinned out inside each tree's mesh) at full detail
/// and with LOD, against each other ([`lod_pair`]'s bounds) and against the offline
/// renderer (64 spp).
///
/// Measured on lavapipe (llvmpipe, Mesa 22.3.6, LLVM 15), 2026-12-02: 73.5 % of the leaf
/// triangles left out; mean radiance +0.5, +0.3, +0.4 %; coverage -0.04 %; LOD vs full MAE
/// 0.0093, SSIM 0.924; against offline MAE 0.0199 (full) and 0.0204 (LOD).
#[test]
fn forest_lod_keeps_brightness_colour_coverage_and_agreement() {
    let Some(ctx) = context() else {
        return;
    };
    let scene = forest();
    let p = lod_pair(&ctx, &scene, "card forest");
    assert!(p.leaves >= 9 * 3000, "{}", p.leaves);
    let (a, b) = (&p.full, &p.lod);
    let (sa, sb) = (to_srgb8(a, &scene.film), to_srgb8(b, &scene.film));
    // LOD must thin the leaves out (the branches stay): each leaf card is two triangles.
    let dropped = (p.tris[0] - p.tris[1]) as f64 / (2 * p.leaves) as f64;
    eprintln!("leaf triangles left out: {:.1} %", 100.0 * dropped);
    assert!(dropped > 0.5, "{:?}", p.tris);
    // Against the offline renderer (every leaf, 64 spp): LOD costs little agreement.
    let cpu = lamina_render::render(
        &scene,
        &lamina_render::RenderOptions {
            spp: Some(64),
            seed: 1,
            ..Default::default()
        },
    )
    .expect("offline render")
    .image;
    let sc = to_srgb8(&cpu, &scene.film);
    let (mae_full, ssim_full) = (mean_abs_error(&sa, &sc), ssim(&sa, &sc, 160, 90));
    let (mae_lod, ssim_lod) = (mean_abs_error(&sb, &sc), ssim(&sb, &sc, 160, 90));
    eprintln!(
        "against offline: full MAE {mae_full:.4} SSIM {ssim_full:.4}; LOD MAE {mae_lod:.4} SSIM \
         {ssim_lod:.4}"
    );
    if let Some(dir) = std::env::var_os("LAMINA_TEST_IMAGES") {
        let path = std::path::Path::new(&dir).join("forest_lod.png");
        let row = common::side_by_side(&common::side_by_side(a, b), &cpu);
        lamina_render::write_image(&path, &row, &scene.film).expect("write");
    }
    assert!(mae_lod < 0.05 && ssim_lod > 0.6, "LOD vs offline");
    assert!(
        mae_lod < mae_full + 0.01,
        "LOD adds {} of MAE",
        mae_lod - mae_full
    );
}

/// A forest of curved leaves placed one instance per leaf (as scene files place an
/// instanced plant's leaves): level of detail thins the leaf instances out and enlarges the
/// rest about their centres, with [`lod_pair`]'s bounds.
///
/// Measured on lavapipe (llvmpipe, Mesa 22.3.6, LLVM 15), 2026-12-02: 72.8 % of the
/// triangles left out; mean radiance +0.4, +0.4, +0.2 %; coverage +1.2 %; LOD vs full MAE
/// 0.0097, SSIM 0.908.
#[test]
fn leaf_instances_thin_out_with_the_same_look() {
    let Some(ctx) = context() else {
        return;
    };
    let plant =
        lamina_plant::generate_plant(&lamina_plant::PlantParams::tree(1, 3000)).expect("tree");
    let scene = lamina_bench::tree_scene(
        plant,
        lamina_bench::Representation::ForestCurved,
        9,
        160,
        90,
        1,
    );
    let p = lod_pair(&ctx, &scene, "curved-leaf forest");
    assert!(p.leaves >= 9 * 2900, "{}", p.leaves);
    let dropped = (p.tris[0] - p.tris[1]) as f64 / p.tris[0] as f64;
    eprintln!("triangles left out: {:.1} %", 100.0 * dropped);
    assert!(dropped > 0.3, "{:?}", p.tris);
}

/// A dolly toward the forest in small steps: the mean change from one frame to the next
/// with LOD is no larger than without (leaves fading in and out do not flicker).
#[test]
fn forest_lod_is_stable_during_a_dolly() {
    let Some(ctx) = context() else {
        return;
    };
    let scene = forest();
    let frames = 12;
    let mut change = [0.0f64; 2];
    for (k, lod_px) in [0.0, 1.0].into_iter().enumerate() {
        let mut r = Renderer::new(&ctx, &scene, settings(lod_px)).expect("renderer");
        let mut last: Option<Vec<u8>> = None;
        for f in 0..frames {
            let mut camera = scene.camera;
            camera.position += (camera.look_at - camera.position) * (0.01 * f as f32);
            let img = r
                .render_view_image(&FrameView {
                    camera,
                    sun_dir: None,
                    width: 160,
                    height: 90,
                })
                .expect("frame");
            let shown = to_srgb8(&img, &scene.film);
            if let Some(prev) = &last {
                change[k] += mean_abs_error(&shown, prev) / (frames - 1) as f64;
            }
            last = Some(shown);
        }
    }
    eprintln!(
        "dolly: mean frame-to-frame MAE {:.5} without LOD, {:.5} with: ratio {:.3}",
        change[0],
        change[1],
        change[1] / change[0]
    );
    assert!(change[1] < 1.15 * change[0], "{change:?}");
}

/// Culling: turned so that part of the forest leaves the frame, the camera draws fewer
/// triangles than the light views (which draw every tree); facing away, none.
#[test]
fn trees_outside_the_view_are_culled_but_still_cast_shadows() {
    let Some(ctx) = context() else {
        return;
    };
    let scene = forest();
    // Frustum culling alone (tests/occlusion.rs checks occlusion culling).
    let frustum_only = RenderSettings {
        occlusion_culling: false,
        ..settings(0.0)
    };
    let mut r = Renderer::new(&ctx, &scene, frustum_only).expect("renderer");
    let view = |look: Vec3| {
        let mut camera = scene.camera;
        camera.look_at = camera.position + look;
        FrameView {
            camera,
            sun_dir: None,
            width: 160,
            height: 90,
        }
    };
    let ahead = scene.camera.look_at - scene.camera.position;
    let side = Vec3::Y.cross(ahead).normalize() * ahead.length();
    let mut drawn = Vec::new();
    for look in [ahead, ahead + 0.8 * side, -ahead] {
        r.render_and_wait(&view(look), None).expect("frame");
        drawn.push(r.drawn_triangles().unwrap().expect("culling runs"));
    }
    eprintln!(
        "[camera, shadow] triangles: ahead {:?}, turned {:?}, away {:?}",
        drawn[0], drawn[1], drawn[2]
    );
    let all = r.triangles();
    assert_eq!(drawn[0], [all, all]);
    assert!(
        drawn[1][0] < all * 3 / 4 && drawn[1][0] > 0,
        "{:?}",
        drawn[1]
    );
    assert_eq!(drawn[1][1], all);
    // Facing away only the ground (a world mesh, 2 triangles) may be in view.
    assert!(drawn[2][0] <= 2, "{:?}", drawn[2]);
    assert_eq!(drawn[2][1], all);
}
