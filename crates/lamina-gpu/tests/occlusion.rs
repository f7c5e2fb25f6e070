//! Two-phase occlusion culling on the GPU path (`renderer/hiz.rs`, `shaders/cull.wgsl`):
//! trees hidden behind a wall are not drawn once a frame has seen them hidden, frames are
//! the same as without occlusion culling, and trees that come into view are drawn in the
//! frame they appear (no frame late). They run on any Vulkan adapter, lavapipe included.

use glam::Vec3;
use lamina_gpu::{ContextOptions, FrameView, GpuContext, RenderSettings, Renderer};
use lamina_scene::{ColorInput, Material, Mesh, Scene};

fn context() -> Option<GpuContext> {
    lamina_gpu::context_for_tests(&ContextOptions::default())
        .expect("a Vulkan adapter (CI installs mesa-vulkan-drivers)")
}

/// The test forest (9 trees of 3000 leaves, 160x90) with an opaque grey wall across the
/// view at a third of the way to the camera's target, wide and tall enough to hide every
/// tree from the camera.
fn walled_forest() -> Scene {
    let mut scene = lamina_bench::frame_forest_scene(9, 3000, (160, 90)).expect("forest");
    let cam = scene.camera;
    let ahead = cam.look_at - cam.position;
    let d = ahead.length() / 3.0;
    let f = ahead.normalize();
    let right = f.cross(Vec3::Y).normalize();
    let up = right.cross(f);
    // The view's half extent at the wall, with room to spare.
    let half = 2.0 * d * (0.5 * cam.fov_deg.to_radians()).tan();
    let centre = cam.position + f * d;
    scene.materials.push(Material::Diffuse {
        name: "wall".into(),
        reflectance: ColorInput::Constant(Vec3::splat(0.4)),
        alpha: None,
    });
    let m = scene.materials.len() as u32 - 1;
    scene.meshes.push(Mesh::quad(
        centre - half * (right + up),
        2.0 * half * right,
        2.0 * half * up,
        m,
    ));
    scene
}

fn view(scene: &Scene, forward: f32) -> FrameView {
    let mut camera = scene.camera;
    let step = (camera.look_at - camera.position) * forward;
    camera.position += step;
    camera.look_at += step;
    FrameView {
        camera,
        sun_dir: None,
        width: 160,
        height: 90,
    }
}

fn renderer(ctx: &GpuContext, scene: &Scene, occlusion: bool) -> Renderer {
    let settings = RenderSettings {
        occlusion_culling: occlusion,
        lod_pixels: 0.0,
        ..Default::default()
    };
    Renderer::new(ctx, scene, settings).expect("renderer")
}

/// One frame of `v` by each renderer (with and without occlusion culling): whether the
/// displayed frames are the same, and the camera triangles each drew.
fn frame_pair(
    occ: &mut Renderer,
    plain: &mut Renderer,
    v: &FrameView,
    scene: &Scene,
) -> (bool, u64, u64) {
    let a = occ.render_screenshot(v, &scene.film, None).expect("frame");
    let b = plain
        .render_screenshot(v, &scene.film, None)
        .expect("frame");
    let [camera, _] = occ.drawn_triangles().unwrap().expect("culling runs");
    let [plain_camera, _] = plain.drawn_triangles().unwrap().expect("culling runs");
    (a == b, camera, plain_camera)
}

/// Behind the wall, the trees stop being drawn from the third frame on (the first finds
/// them in view with nothing drawn yet, the second finds them hidden); every frame is
/// the frame drawn without occlusion culling; stepping through the wall, the trees are
/// drawn in the first frame that sees them.
#[test]
fn hidden_trees_are_skipped_and_frames_do_not_change() {
    let Some(ctx) = context() else {
        return;
    };
    let scene = walled_forest();
    let mut occ = renderer(&ctx, &scene, true);
    let mut plain = renderer(&ctx, &scene, false);
    let all = occ.triangles();
    let behind = view(&scene, 0.0);
    let mut drawn = Vec::new();
    for frame in 0..4 {
        let (same, camera, _) = frame_pair(&mut occ, &mut plain, &behind, &scene);
        let [_, shadow] = occ.drawn_triangles().unwrap().expect("culling runs");
        eprintln!(
            "behind the wall, frame {frame}: camera triangles {camera} of {all}, shadow {shadow}"
        );
        assert!(
            same,
            "frame {frame} differs from the frame without occlusion culling"
        );
        assert_eq!(shadow, all, "the light views draw every tree");
        drawn.push(camera);
    }
    assert!(drawn[0] > all / 2 && drawn[1] > all / 2, "{drawn:?}");
    // Only the ground, the wall and tree parts the wall leaves in view.
    assert!(
        drawn[2] < all / 20 && drawn[3] == drawn[2],
        "{drawn:?} of {all}"
    );
    // Through the wall: the trees are back in the first frame.
    let (same, camera, plain_camera) = frame_pair(&mut occ, &mut plain, &view(&scene, 0.5), &scene);
    eprintln!("past the wall: camera triangles {camera}, without occlusion culling {plain_camera}");
    assert!(same, "the first frame past the wall misses trees");
    assert_eq!(camera, plain_camera);
}

/// Stepping sideways out from behind the wall, trees come into view a few at a time:
/// every frame is the frame drawn without occlusion culling (nothing pops in a frame
/// late), and fewer triangles are drawn while part of the forest is hidden.
#[test]
fn trees_coming_out_from_behind_the_wall_are_drawn_at_once() {
    let Some(ctx) = context() else {
        return;
    };
    let scene = walled_forest();
    let mut occ = renderer(&ctx, &scene, true);
    let mut plain = renderer(&ctx, &scene, false);
    let cam = scene.camera;
    let ahead = cam.look_at - cam.position;
    let right = ahead.normalize().cross(Vec3::Y).normalize();
    // The wall reaches 2 d tan(fov / 2) to each side of the view's centre line, d a third
    // of the way to the target: the camera steps out past its edge in 10 frames.
    let edge = 2.0 * ahead.length() / 3.0 * (0.5 * cam.fov_deg.to_radians()).tan();
    let mut saved = 0u64;
    for frame in 0..=10 {
        let mut v = view(&scene, 0.0);
        let step = right * (1.6 * edge * frame as f32 / 10.0);
        v.camera.position += step;
        v.camera.look_at += step;
        let (same, camera, plain_camera) = frame_pair(&mut occ, &mut plain, &v, &scene);
        eprintln!(
            "frame {frame}: camera triangles {camera}, without occlusion culling {plain_camera}"
        );
        assert!(
            same,
            "frame {frame} differs from the frame without occlusion culling"
        );
        assert!(camera <= plain_camera);
        saved += plain_camera - camera;
    }
    assert!(saved > 0, "something was hidden on the way");
}
