//! End-to-end tests of the renderer on small scenes built in code.

use crate::{Image, RenderOptions, render, write_image};
use glam::{Vec2, Vec3, Vec4};
use lamina_core::{
    AlphaMask, Camera, ColorInput, Film, Integrator, Light, Material, Mesh, PixelFilter, Scene,
    Sky, ToneMap,
};
use lamina_leaf::{Texture, Wrap};
use std::f32::consts::PI;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// A `2·half` square card in the plane `z = z0`, front (counter-clockwise) facing `+z`,
/// UVs over `[0, 1]²` with `u` along `+x`.
pub(crate) fn card(half: f32, z0: f32, material: u32) -> Mesh {
    Mesh {
        positions: vec![
            Vec3::new(-half, -half, z0),
            Vec3::new(half, -half, z0),
            Vec3::new(half, half, z0),
            Vec3::new(-half, half, z0),
        ],
        normals: vec![],
        tangents: Vec::new(),
        uvs: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
    }
}

pub(crate) fn film(w: u32, h: u32, spp: u32) -> Film {
    Film {
        width: w,
        height: h,
        spp,
        filter: PixelFilter::Box,
        exposure: 0.0,
        tonemap: ToneMap::Clamp,
    }
}

pub(crate) fn camera_at(z: f32, fov_deg: f32) -> Camera {
    Camera {
        position: Vec3::new(0.0, 0.0, z),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        fov_deg,
        aperture_radius: 0.0,
        focus_distance: 1.0,
    }
}

fn diffuse(r: f32) -> Material {
    Material::Diffuse {
        name: "d".into(),
        reflectance: ColorInput::Constant(Vec3::splat(r)),
        alpha: None,
    }
}

fn diffuse_transmission(r: Vec3, t: Vec3) -> Material {
    Material::DiffuseTransmission {
        name: "dt".into(),
        reflectance: ColorInput::Constant(r),
        transmittance: ColorInput::Constant(t),
        alpha: None,
    }
}

pub(crate) fn opts(spp: u32, threads: usize) -> RenderOptions {
    RenderOptions {
        spp: Some(spp),
        threads: Some(threads),
        seed: 7,
        ..Default::default()
    }
}

/// (a) A Lambertian card filling the view under a sun at θ from the normal: every pixel is
/// `R cos θ E / π` lit from the front and `T cos θ E / π` lit from behind.
///
/// Tolerance: with a zero-diameter sun the estimator has no variance at all (one delta light
/// sample, no sky, nothing else to bounce off), so the check is 1e-4 relative (float
/// rounding). With the real sun's 0.53° disc the light sample is a cone sample and BSDF
/// samples hit the disc with probability ~1e-5 at negligible MIS weight. The average cosine
/// over the disc differs from `cos θ` by ~θmax² ≈ 2e-5, but one sample's cosine differs from
/// it by up to `tan θ · θmax` (0.8 % at 60°, θmax = 0.265°): per pixel (4 stratified samples)
/// the tolerance is 0.5 %, and the image mean (768 samples) must be within 1e-3.
#[test]
fn lambertian_card_matches_analytic_sun_value() {
    let e = Vec3::new(1000.0, 800.0, 600.0);
    let (r, t) = (Vec3::new(0.3, 0.5, 0.1), Vec3::new(0.2, 0.4, 0.05));
    for theta_deg in [0.0f32, 30.0, 60.0] {
        let th = theta_deg.to_radians();
        for diameter in [0.0f32, 0.53] {
            for integrator in [
                Integrator::Path {
                    max_depth: 4,
                    rr_depth: 2,
                },
                Integrator::Paper {
                    ambient: Some(Vec3::ZERO),
                },
            ] {
                for (mat, refl, trans) in [
                    (diffuse(0.3), Vec3::splat(0.3), Vec3::ZERO),
                    (diffuse_transmission(r, t), r, t),
                ] {
                    for front in [true, false] {
                        let dir =
                            Vec3::new(th.sin(), 0.0, if front { th.cos() } else { -th.cos() });
                        let scene = Scene {
                            camera: camera_at(1.0, 60.0),
                            film: film(16, 12, 4),
                            integrator,
                            lights: vec![Light::Sun {
                                direction: dir,
                                irradiance: e,
                                angular_diameter_deg: diameter,
                            }],
                            sky: None,
                            materials: vec![mat.clone()],
                            meshes: vec![card(4.0, 0.0, 0)],
                            prototypes: Vec::new(),
                            instances: Vec::new(),
                        };
                        let out = render(&scene, &opts(4, 2)).unwrap();
                        let expect = if front { refl } else { trans } * th.cos() * e / PI;
                        let tol = if diameter == 0.0 { 1e-4 } else { 5e-3 };
                        let m = out.image.mean();
                        assert!(
                            (m - expect).abs().max_element()
                                <= 1e-3 * expect.max_element().max(1e-3),
                            "mean {m} vs {expect}"
                        );
                        for p in &out.image.pixels {
                            let err = (*p - expect).abs().max_element();
                            assert!(
                                err <= tol * expect.max_element().max(1e-3),
                                "θ={theta_deg} d={diameter} front={front} {integrator:?}: {p} vs {expect}"
                            );
                        }
                    }
                }
            }
        }
    }
}

/// (b) Furnace: white surfaces (opaque R = 1, and R + T = 1 cards) in a constant sky of
/// radiance 1: every pixel converges to 1 (no energy created or lost).
#[test]
fn furnace_is_energy_conserving() {
    let mut tilted = card(0.6, 0.0, 1);
    for p in &mut tilted.positions {
        *p = Vec3::new(p.x, p.y * 0.6, p.z + p.y * 0.8 + 0.3);
    }
    let mut upright = card(0.5, 0.0, 2);
    for p in &mut upright.positions {
        *p = Vec3::new(p.z - 0.2, p.y, p.x);
    }
    let scene = Scene {
        camera: camera_at(2.5, 50.0),
        film: film(24, 24, 256),
        integrator: Integrator::Path {
            max_depth: 100,
            rr_depth: 3,
        },
        lights: vec![],
        sky: Some(Sky::Constant(Vec3::ONE)),
        materials: vec![
            diffuse(1.0),
            diffuse_transmission(Vec3::new(0.6, 0.5, 0.9), Vec3::new(0.4, 0.5, 0.1)),
            diffuse_transmission(Vec3::splat(0.5), Vec3::splat(0.5)),
        ],
        meshes: vec![card(0.8, -0.3, 0), tilted, upright],
        prototypes: Vec::new(),
        instances: Vec::new(),
    };
    let out = render(&scene, &opts(256, 2)).unwrap();
    let m = out.image.mean();
    assert!(
        (m - Vec3::ONE).abs().max_element() < 0.005,
        "image mean {m}"
    );
    for p in &out.image.pixels {
        assert!((*p - Vec3::ONE).abs().max_element() < 0.15, "pixel {p}");
    }
}

/// (c) A card whose matte is transparent on its left half (`u < 0.5`) over an opaque ground,
/// under a delta sun at 45°: camera rays see the ground through the left half, shadow rays
/// from the ground pass the left half and are blocked by the right half.
#[test]
fn alpha_matte_lets_camera_and_shadow_rays_through() {
    let matte = Texture::from_texels(2, 1, vec![Vec4::ZERO, Vec4::ONE], Wrap::Clamp);
    let card_mat = Material::Diffuse {
        name: "matte".into(),
        reflectance: ColorInput::Constant(Vec3::splat(0.5)),
        alpha: Some(AlphaMask {
            map: matte,
            use_alpha_channel: false,
            cutoff: 0.5,
        }),
    };
    let e = 100.0;
    let scene = Scene {
        camera: camera_at(20.0, 4.0), // ±0.7 m at the ground, nearly orthographic
        film: film(40, 8, 4),
        integrator: Integrator::Path {
            max_depth: 1,
            rr_depth: 5,
        },
        lights: vec![Light::Sun {
            direction: Vec3::new(1.0, 0.0, 1.0),
            irradiance: Vec3::splat(e),
            angular_diameter_deg: 0.0,
        }],
        sky: None,
        materials: vec![diffuse(0.8), card_mat],
        meshes: vec![card(5.0, 0.0, 0), card(1.0, 0.5, 1)],
        prototypes: Vec::new(),
        instances: Vec::new(),
    };
    let out = render(&scene, &opts(4, 2)).unwrap();
    let row = 4;
    let c = (PI / 4.0).cos() * e / PI;
    // Pixel column x covers world x ≈ (x + 0.5 - 20) / 20 · 0.7 at the card.
    let lit_ground = out.image.at(3, row).x; // x ≈ -0.6: seen through the hole, lit through it
    let shadowed_ground = out.image.at(15, row).x; // x ≈ -0.17: through the hole, in the shadow of the right half
    let card_px = out.image.at(32, row).x; // x ≈ 0.43: the opaque half
    assert!(
        (lit_ground - 0.8 * c).abs() < 1e-3 * c,
        "lit ground {lit_ground}"
    );
    assert!(
        shadowed_ground.abs() < 1e-6,
        "shadowed ground {shadowed_ground}"
    );
    assert!((card_px - 0.5 * c).abs() < 1e-3 * c, "card {card_px}");
}

fn small_canopy_scene() -> Scene {
    let mut meshes = Vec::new();
    for i in 0..12 {
        let mut m = card(0.3, 0.0, (i % 2) as u32);
        let a = i as f32 * 0.9;
        for p in &mut m.positions {
            let q = Vec3::new(p.x * a.cos(), p.y, p.x * a.sin() + p.y * 0.3);
            *p = q + Vec3::new(
                (i as f32 * 0.37).sin() * 0.6,
                (i as f32 * 0.61).cos() * 0.6,
                0.0,
            );
        }
        meshes.push(m);
    }
    Scene {
        camera: camera_at(3.0, 50.0),
        film: Film {
            filter: PixelFilter::Gaussian {
                radius: 1.5,
                sigma: 0.5,
            },
            ..film(40, 30, 8)
        },
        integrator: Integrator::Path {
            max_depth: 6,
            rr_depth: 2,
        },
        lights: vec![
            Light::Sun {
                direction: Vec3::new(0.3, 1.0, 0.5),
                irradiance: Vec3::splat(500.0),
                angular_diameter_deg: 0.53,
            },
            Light::Quad {
                corner: Vec3::new(-1.0, 1.5, -1.0),
                edge_u: Vec3::new(2.0, 0.0, 0.0),
                edge_v: Vec3::new(0.0, 0.0, 2.0),
                radiance: Vec3::splat(5.0),
                two_sided: false,
            },
            Light::Sphere {
                center: Vec3::new(1.0, -1.0, 1.0),
                radius: 0.2,
                radiance: Vec3::new(20.0, 10.0, 5.0),
            },
            Light::Point {
                position: Vec3::new(-1.0, 0.0, 1.5),
                intensity: Vec3::splat(3.0),
            },
        ],
        sky: Some(Sky::Constant(Vec3::new(0.2, 0.3, 0.5))),
        materials: vec![
            diffuse_transmission(Vec3::new(0.1, 0.3, 0.05), Vec3::new(0.1, 0.4, 0.05)),
            diffuse(0.6),
        ],
        meshes,
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// (d) Same seed → bit-identical image with 1 and 2 threads; another seed differs.
#[test]
fn deterministic_across_thread_counts() {
    let scene = small_canopy_scene();
    let a = render(&scene, &opts(8, 1)).unwrap();
    let b = render(&scene, &opts(8, 2)).unwrap();
    assert!(a.image.pixels.iter().all(|p| p.is_finite()));
    assert_eq!(a.image, b.image);
    assert_eq!(a.stats.rays, b.stats.rays);
    let c = render(
        &scene,
        &RenderOptions {
            seed: 8,
            ..opts(8, 2)
        },
    )
    .unwrap();
    assert_ne!(a.image, c.image);
    assert!(a.image.mean().max_element() > 0.0);
}

/// (e) A time limit or the cancel flag returns a valid image of the completed passes.
#[test]
fn time_limit_and_cancel_return_valid_images() {
    let scene = small_canopy_scene();
    let out = render(
        &scene,
        &RenderOptions {
            time_limit: Some(Duration::from_millis(300)),
            ..opts(1_000_000, 2)
        },
    )
    .unwrap();
    assert!(out.stats.stopped_early);
    assert!(out.stats.spp_done >= 1 && out.stats.spp_done < 1_000_000);
    assert!(out.stats.elapsed < Duration::from_secs(5));
    assert!(out.image.pixels.iter().all(|p| p.is_finite()));
    assert!(out.image.mean().max_element() > 0.0);

    let cancel = Arc::new(AtomicBool::new(false));
    let flag = cancel.clone();
    let out = render(
        &scene,
        &RenderOptions {
            cancel: Some(cancel),
            progress: Some(Arc::new(move |p| {
                if p.passes_done == 2 {
                    flag.store(true, Ordering::Relaxed);
                }
            })),
            ..opts(64, 2)
        },
    )
    .unwrap();
    assert!(out.stats.stopped_early);
    assert_eq!(out.stats.spp_done, 2);
    assert!(out.image.pixels.iter().all(|p| p.is_finite()));
    // The two-pass image equals a plain 2-spp render.
    assert_eq!(out.image, render(&scene, &opts(2, 2)).unwrap().image);
}

/// Bad options fail cleanly.
#[test]
fn bad_options_are_errors() {
    let scene = small_canopy_scene();
    assert!(render(&scene, &opts(0, 2)).is_err());
    assert!(render(&scene, &opts(1, 0)).is_err());
    let mut bad = scene.clone();
    bad.camera.look_at = bad.camera.position;
    assert!(render(&bad, &opts(1, 1)).is_err());
    let mut bad = scene;
    bad.meshes[0].material = 99;
    assert!(render(&bad, &opts(1, 1)).is_err());
}

/// (f, in the renderer) An image sky of constant radiance renders like the constant sky: the
/// importance sampling is unbiased.
#[test]
fn image_sky_furnace() {
    let tex = Texture::from_texels(8, 4, vec![Vec4::new(0.5, 0.5, 0.5, 1.0); 32], Wrap::Repeat);
    let scene = Scene {
        camera: camera_at(2.0, 40.0),
        film: film(12, 12, 32),
        integrator: Integrator::Path {
            max_depth: 20,
            rr_depth: 3,
        },
        lights: vec![],
        sky: Some(Sky::Image {
            map: tex,
            scale: 2.0,
            rotation_deg: 10.0,
        }),
        materials: vec![diffuse_transmission(Vec3::splat(0.7), Vec3::splat(0.3))],
        meshes: vec![card(0.5, 0.0, 0)],
        prototypes: Vec::new(),
        instances: Vec::new(),
    };
    let out = render(&scene, &opts(32, 2)).unwrap();
    for p in &out.image.pixels {
        assert!((*p - Vec3::ONE).abs().max_element() < 0.1, "{p}");
    }
    assert!((out.image.mean() - Vec3::ONE).abs().max_element() < 0.01);
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("lamina-render-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// (g) EXR and PNG are valid, hold the right values, leave no temporary file; an unwritable
/// directory is a clean error that leaves nothing behind.
#[test]
fn output_files_are_valid_and_atomic() {
    let dir = temp_dir("out");
    let img = Image {
        width: 3,
        height: 2,
        pixels: vec![
            Vec3::new(0.0, 0.5, 1.0),
            Vec3::new(2.0, 0.25, 0.01),
            Vec3::ZERO,
            Vec3::ONE,
            Vec3::new(0.1, 0.2, 0.3),
            Vec3::splat(100.0),
        ],
    };
    let f = film(3, 2, 1);
    let exr = dir.join("a.exr");
    write_image(&exr, &img, &f).unwrap();
    let back = image::open(&exr).unwrap().into_rgb32f();
    assert_eq!((back.width(), back.height()), (3, 2));
    for (p, q) in back.pixels().zip(&img.pixels) {
        assert_eq!(Vec3::from_array(p.0), *q);
    }
    let png = dir.join("b.PNG");
    write_image(&png, &img, &f).unwrap();
    let back = image::open(&png).unwrap().into_rgb8();
    assert_eq!(back.get_pixel(0, 0).0, [0, 188, 255]);
    assert_eq!(back.get_pixel(2, 1).0, [255, 255, 255]);
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");

    // Tone maps and exposure.
    let mut fr = f;
    fr.tonemap = ToneMap::Reinhard;
    fr.exposure = 1.0;
    write_image(&png, &img, &fr).unwrap();
    let back = image::open(&png).unwrap().into_rgb8();
    // 0.5 · 2 = 1 → 1/2 → sRGB 0.735 → 188.
    assert_eq!(back.get_pixel(0, 0).0[1], 188);

    let missing = dir.join("no/such/dir/c.png");
    let err = write_image(&missing, &img, &f).unwrap_err().to_string();
    assert!(err.contains("c.png"), "{err}");
    let file_as_dir = exr.join("d.exr");
    assert!(write_image(&file_as_dir, &img, &f).is_err());
    assert!(write_image(&dir.join("e.jpg"), &img, &f).is_err());
    let bad = Image {
        width: 4,
        ..img.clone()
    };
    assert!(write_image(&dir.join("f.png"), &bad, &f).is_err());
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Area lights against closed forms, through NEE + MIS with BSDF sampling: a Lambertian
/// floor under a square quad light (the rectangle form factor) and under a sphere light
/// (`E = π L (r/d)²`), and under a point light (`E = I / d²`). The camera looks at a ~1 cm
/// patch below the light from the side, so the irradiance is constant across the image to
/// 1e-4. Tolerance 1 % on the image mean (2,304 samples; the estimators' relative standard
/// deviation per sample is below 0.3).
#[test]
fn area_lights_match_analytic_irradiance() {
    // Form factor from a point to a w x l rectangle above one of its corners, at height h.
    let corner_ff = |w: f32, l: f32, h: f32| {
        let (x, y) = (w / h, l / h);
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
    };
    let (half, h, l_e, r) = (0.25f32, 1.0f32, 10.0f32, 0.6f32);
    let quad_e = PI * l_e * 4.0 * corner_ff(half, half, h);
    let (radius, d) = (0.2f32, 1.0f32);
    let sphere_e = PI * l_e * (radius / d).powi(2);
    let intensity = 5.0f32;
    let cases = [
        (
            Light::Quad {
                corner: Vec3::new(-half, half, h),
                edge_u: Vec3::new(2.0 * half, 0.0, 0.0),
                edge_v: Vec3::new(0.0, -2.0 * half, 0.0),
                radiance: Vec3::splat(l_e),
                two_sided: false,
            },
            quad_e,
        ),
        (
            Light::Sphere {
                center: Vec3::new(0.0, 0.0, d),
                radius,
                radiance: Vec3::splat(l_e),
            },
            sphere_e,
        ),
        (
            Light::Point {
                position: Vec3::new(0.0, 0.0, d),
                intensity: Vec3::splat(intensity),
            },
            intensity / (d * d),
        ),
    ];
    for (light, e) in cases {
        let scene = Scene {
            camera: Camera {
                position: Vec3::new(2.0, 0.0, 0.8),
                look_at: Vec3::ZERO,
                up: Vec3::Z,
                fov_deg: 0.3,
                aperture_radius: 0.0,
                focus_distance: 1.0,
            },
            film: film(6, 6, 64),
            integrator: Integrator::Path {
                max_depth: 1,
                rr_depth: 5,
            },
            lights: vec![light.clone()],
            sky: None,
            materials: vec![diffuse(r)],
            meshes: vec![card(5.0, 0.0, 0)],
            prototypes: Vec::new(),
            instances: Vec::new(),
        };
        let out = render(&scene, &opts(64, 2)).unwrap();
        let m = out.image.mean().x;
        let expect = r * e / PI;
        assert!(
            (m - expect).abs() < 0.01 * expect,
            "{light:?}: {m} vs {expect}"
        );
    }
}

// ---------------------------------------------------------------------------------------
// Instancing: two-level BVH.

use crate::Accel;
use crate::accel::{HitKind, Ray};
use glam::{Affine3A, Quat};
use lamina_core::{Instance, Prototype};

/// `mesh` moved to world space by `m` the way scene loaders flatten transformed meshes:
/// positions transformed, winding reversed when `m` mirrors (front faces stay in front).
fn flatten(mesh: &Mesh, m: Affine3A) -> Mesh {
    let mut out = mesh.clone();
    for p in &mut out.positions {
        *p = m.transform_point3(*p);
    }
    if m.matrix3.determinant() < 0.0 {
        for t in &mut out.indices {
            t.swap(1, 2);
        }
    }
    out
}

/// The test placements: a rotation, a rotation with non-uniform scale, and a mirror.
fn test_transforms() -> Vec<Affine3A> {
    vec![
        Affine3A::from_rotation_translation(
            Quat::from_rotation_y(0.7) * Quat::from_rotation_x(-0.3),
            Vec3::new(-0.9, 0.1, -0.5),
        ),
        Affine3A::from_scale_rotation_translation(
            Vec3::new(1.6, 0.5, 0.8),
            Quat::from_rotation_z(0.4) * Quat::from_rotation_y(-1.1),
            Vec3::new(0.8, -0.3, 0.2),
        ),
        Affine3A::from_scale_rotation_translation(
            Vec3::new(-1.0, 1.0, 1.0),
            Quat::from_rotation_y(0.5),
            Vec3::new(0.1, 0.6, -0.8),
        ),
    ]
}

/// [`small_canopy_scene`] with its cards as one prototype placed by `transforms`, and the
/// same scene flattened into world-space meshes.
fn instanced_and_flat(transforms: &[Affine3A]) -> (Scene, Scene) {
    let base = small_canopy_scene();
    let mut inst = base.clone();
    inst.meshes = Vec::new();
    inst.prototypes = vec![Prototype {
        name: "cards".into(),
        meshes: base.meshes.clone(),
    }];
    inst.instances = transforms
        .iter()
        .map(|&transform| Instance {
            prototype: 0,
            transform,
        })
        .collect();
    // A ground card in world space, shared by both.
    let ground = {
        let mut g = card(3.0, 0.0, 1);
        for p in &mut g.positions {
            *p = Vec3::new(p.x, -1.2, p.y);
        }
        g.indices = vec![[0, 2, 1], [0, 3, 2]]; // facing +y
        g
    };
    inst.meshes.push(ground.clone());
    let mut flat = base;
    flat.meshes = transforms
        .iter()
        .flat_map(|&m| flat.meshes.iter().map(move |mesh| flatten(mesh, m)))
        .collect();
    flat.meshes.push(ground);
    (inst, flat)
}

/// Instanced geometry answers every query like the same geometry flattened into world
/// space: closest hit (distance, position, adaxial normal, dP/du, uv, material) and any-hit,
/// through rotations, non-uniform scale and a mirror. Rays that graze an edge may differ by
/// rounding, so a few disagreements (< 1 %) are allowed, never a wrong frame.
#[test]
fn instanced_queries_match_flattened_geometry() {
    let (inst, flat) = instanced_and_flat(&test_transforms());
    let (a, b) = (Accel::build(&inst).unwrap(), Accel::build(&flat).unwrap());
    assert_eq!(a.instance_count(), 3);
    let (mut n, mut hits, mut disagree) = (0, 0, 0);
    for i in 0..4000u32 {
        let s = crate::sampler::sobol_2d(i, 3);
        let q = crate::sampler::sobol_2d(i, 4);
        let origin = Vec3::new(s.x * 4.0 - 2.0, s.y * 4.0 - 2.0, 3.0);
        let target = Vec3::new(q.x * 3.0 - 1.5, q.y * 3.0 - 1.5, (q.x - q.y) * 2.0 - 1.0);
        let ray = Ray {
            origin,
            dir: (target - origin).normalize(),
            tmax: f32::INFINITY,
        };
        n += 1;
        let (ha, hb) = (a.intersect(&ray), b.intersect(&ray));
        assert_eq!(a.occluded(&ray), ha.is_some());
        match (ha, hb) {
            (None, None) => {}
            (Some(ha), Some(hb)) if (ha.t - hb.t).abs() < 1e-4 * hb.t => {
                hits += 1;
                let (
                    HitKind::Triangle { prim: pa, bary: ba },
                    HitKind::Triangle { prim: pb, bary: bb },
                ) = (ha.kind, hb.kind)
                else {
                    assert_eq!(ha.kind, hb.kind, "both hit the same sphere light");
                    continue;
                };
                let (xa, ia) = a.surface(pa, ba);
                let (xb, ib) = b.surface(pb, bb);
                assert!((xa - xb).length() < 1e-4, "position {xa} vs {xb}");
                assert!(ia.n.dot(ib.n) > 0.9999, "normal {} vs {}", ia.n, ib.n);
                assert!(ia.s.dot(ib.s) > 0.999, "dP/du {} vs {}", ia.s, ib.s);
                assert!(ia.s.dot(ia.n).abs() < 1e-4);
                assert!((ia.uv_at(ba) - ib.uv_at(bb)).length() < 1e-4);
                // Material (and alpha flag); a mirrored card may be stored as a
                // parallelogram on one side and as two triangles on the other.
                // The UV-mirror flag is relative to each BLAS's own winding: compare the
                // normal-map frames it gives instead.
                let q = crate::accel::FLAG_QUAD | crate::accel::FLAG_UV_MIRRORED;
                assert_eq!(ia.flags & !q, ib.flags & !q);
                let (ta, sa) = a.uv_tangent(pa, ba);
                let (tb, sb) = b.uv_tangent(pb, bb);
                let (ta, tb) = (ta.normalize(), tb.normalize());
                assert!(ta.dot(tb) > 0.999, "tangent {ta} vs {tb}");
                let (ba_, bb_) = (ia.n.cross(ta) * sa, ib.n.cross(tb) * sb);
                assert!(ba_.dot(bb_) > 0.999, "bitangent {ba_} vs {bb_}");
            }
            _ => disagree += 1,
        }
    }
    assert!(hits > n / 4, "{hits} of {n} rays hit");
    assert!(disagree * 100 < n, "{disagree} of {n} rays disagree");
}

/// Rendered images of instanced and flattened geometry agree: each pixel's samples use
/// the same random numbers, so only rounding differences remain (tiny, in a few pixels).
/// With identity transforms the geometry is bit-identical and so is almost every pixel.
#[test]
fn instanced_render_matches_flattened_render() {
    for transforms in [test_transforms(), vec![Affine3A::IDENTITY]] {
        let (inst, flat) = instanced_and_flat(&transforms);
        let a = render(&inst, &opts(8, 2)).unwrap().image;
        let b = render(&flat, &opts(8, 2)).unwrap().image;
        let (ma, mb) = (a.mean(), b.mean());
        assert!(mb.max_element() > 0.01, "not black: {mb}");
        assert!(
            (ma - mb).abs().max_element() < 0.01 * mb.max_element(),
            "{ma} vs {mb}"
        );
        let peak = b.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max);
        let off = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .filter(|(p, q)| (**p - **q).abs().max_element() > 1e-3 * peak)
            .count();
        assert!(
            off * 50 < a.pixels.len(),
            "{off} of {} pixels differ",
            a.pixels.len()
        );
    }
}

/// Test (c) with the matte card as an instance (non-uniformly scaled unit card), and again
/// mirrored with the sun on the other side: the mirror moves the transparent half to the
/// right but keeps the adaxial side toward `+z`; camera and shadow rays pass the holes.
#[test]
fn alpha_tested_instances_cast_shadows_through_holes() {
    let matte = Texture::from_texels(2, 1, vec![Vec4::ZERO, Vec4::ONE], Wrap::Clamp);
    let card_mat = Material::Diffuse {
        name: "matte".into(),
        reflectance: ColorInput::Constant(Vec3::splat(0.5)),
        alpha: Some(AlphaMask {
            map: matte,
            use_alpha_channel: false,
            cutoff: 0.5,
        }),
    };
    let e = 100.0;
    let c = (PI / 4.0).cos() * e / PI;
    // (mirror, sun x, lit ground px, shadowed ground px, card px)
    for (mirror, sun_x, lit, shadowed, card_px) in [(1.0, 1.0, 3, 15, 32), (-1.0, -1.0, 36, 24, 7)]
    {
        let scene = Scene {
            camera: camera_at(20.0, 4.0),
            film: film(40, 8, 4),
            integrator: Integrator::Path {
                max_depth: 1,
                rr_depth: 5,
            },
            lights: vec![Light::Sun {
                direction: Vec3::new(sun_x, 0.0, 1.0),
                irradiance: Vec3::splat(e),
                angular_diameter_deg: 0.0,
            }],
            sky: None,
            materials: vec![diffuse(0.8), card_mat.clone()],
            meshes: vec![card(5.0, 0.0, 0)],
            prototypes: vec![Prototype {
                name: "unit card".into(),
                meshes: vec![card(0.5, 0.0, 1)],
            }],
            instances: vec![Instance {
                prototype: 0,
                transform: Affine3A::from_scale_rotation_translation(
                    Vec3::new(2.0 * mirror, 2.0, 3.0),
                    Quat::IDENTITY,
                    Vec3::new(0.0, 0.0, 0.5),
                ),
            }],
        };
        let out = render(&scene, &opts(4, 2)).unwrap();
        let px = |x| out.image.at(x, 4).x;
        assert!(
            (px(lit) - 0.8 * c).abs() < 1e-3 * c,
            "lit ground {}",
            px(lit)
        );
        assert!(
            px(shadowed).abs() < 1e-6,
            "shadowed ground {}",
            px(shadowed)
        );
        assert!(
            (px(card_px) - 0.5 * c).abs() < 1e-3 * c,
            "card {}",
            px(card_px)
        );
    }
}

/// Instanced scenes render bit-identically for any thread count.
#[test]
fn instanced_render_is_deterministic() {
    let (inst, _) = instanced_and_flat(&test_transforms());
    let a = render(&inst, &opts(4, 1)).unwrap();
    let b = render(&inst, &opts(4, 2)).unwrap();
    assert_eq!(a.image, b.image);
    assert_eq!(a.stats.rays, b.stats.rays);
    assert!(a.image.mean().max_element() > 0.0);
}

/// Bad instances are errors, not panics; memory is counted per level.
#[test]
fn instance_errors_and_memory() {
    let (mut inst, _) = instanced_and_flat(&test_transforms());
    let mem = Accel::build(&inst).unwrap().memory();
    assert_eq!(mem.instance_count, 3);
    assert!(mem.prototypes > 0 && mem.world > 0 && mem.instances >= 3 * 52);
    assert!(mem.bytes_per_instance() >= 52.0);
    inst.instances[1].transform = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    assert!(Accel::build(&inst).is_err(), "singular transform");
    inst.instances[1].transform = Affine3A::IDENTITY;
    inst.instances[2].prototype = 5;
    assert!(Accel::build(&inst).is_err(), "prototype out of range");
}

// ---------------------------------------------------------------------------------------
// Shading normals.

/// A UV sphere of `stacks x slices` quads (triangle fans at the poles are degenerate and
/// dropped by the BVH build), wound counter-clockwise seen from outside. With `smooth` its
/// vertex normals are the analytic ones, `(p - center) / radius`; otherwise it has none.
fn uv_sphere(
    center: Vec3,
    radius: f32,
    stacks: u32,
    slices: u32,
    smooth: bool,
    material: u32,
) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..=stacks {
        let th = PI * i as f32 / stacks as f32;
        for j in 0..=slices {
            let ph = 2.0 * PI * j as f32 / slices as f32;
            let n = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
            positions.push(center + radius * n);
            normals.push(n);
        }
    }
    let at = |i: u32, j: u32| i * (slices + 1) + j;
    let mut indices = Vec::new();
    for i in 0..stacks {
        for j in 0..slices {
            for mut t in [
                [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
            ] {
                let p = t.map(|k| positions[k as usize]);
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                if n.dot(p[0] + p[1] + p[2] - 3.0 * center) < 0.0 {
                    t.swap(1, 2);
                }
                indices.push(t);
            }
        }
    }
    Mesh {
        tangents: Vec::new(),
        uvs: positions
            .iter()
            .enumerate()
            .map(|(k, _)| {
                let (i, j) = (k as u32 / (slices + 1), k as u32 % (slices + 1));
                Vec2::new(j as f32 / slices as f32, 1.0 - i as f32 / stacks as f32)
            })
            .collect(),
        positions,
        normals: if smooth { normals } else { Vec::new() },
        indices,
        material,
    }
}

/// `mesh` with every triangle given its own three vertices, with vertex normals equal to
/// the triangle's geometric normal (`Some`) or none.
fn faceted(mesh: &Mesh, with_normals: bool) -> Mesh {
    let mut out = Mesh {
        positions: Vec::new(),
        normals: Vec::new(),
        tangents: Vec::new(),
        uvs: Vec::new(),
        indices: Vec::new(),
        material: mesh.material,
    };
    for t in &mesh.indices {
        let p = t.map(|k| mesh.positions[k as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        let base = out.positions.len() as u32;
        for k in 0..3 {
            out.positions.push(p[k]);
            out.uvs.push(mesh.uvs[t[k] as usize]);
            if with_normals {
                out.normals.push(n);
            }
        }
        out.indices.push([base, base + 1, base + 2]);
    }
    out
}

pub(crate) fn sun(direction: Vec3, irradiance: f32) -> Light {
    Light::Sun {
        direction,
        irradiance: Vec3::splat(irradiance),
        angular_diameter_deg: 0.0,
    }
}

fn sphere_scene(mesh: Mesh, lights: Vec<Light>, sky: Option<Sky>) -> Scene {
    Scene {
        camera: camera_at(4.0, 40.0),
        film: film(24, 24, 8),
        integrator: Integrator::Path {
            max_depth: 4,
            rr_depth: 2,
        },
        lights,
        sky,
        materials: vec![
            diffuse(0.5),
            diffuse_transmission(Vec3::splat(0.3), Vec3::splat(0.4)),
        ],
        meshes: vec![mesh],
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// Vertex normals equal to the geometric normal change nothing: a faceted sphere and a
/// card carrying them render bit-identically to the same meshes without normals (they are
/// stored flat, the card still becomes one parallelogram), for both integrators and both
/// kinds of material.
#[test]
fn normals_equal_to_geometric_render_identically() {
    let sphere = uv_sphere(Vec3::new(0.2, -0.1, 0.0), 0.8, 6, 12, false, 0);
    for material in [0, 1] {
        for integrator in [
            Integrator::Path {
                max_depth: 4,
                rr_depth: 2,
            },
            Integrator::Paper { ambient: None },
        ] {
            let build = |with_normals: bool| {
                let mut s = faceted(&sphere, with_normals);
                s.material = material;
                let mut c = card(2.0, -1.0, material);
                if with_normals {
                    c.normals = vec![Vec3::Z; 4];
                }
                let mut scene = sphere_scene(
                    s,
                    vec![sun(Vec3::new(0.4, 0.5, 0.7).normalize(), 3.0)],
                    Some(Sky::Constant(Vec3::splat(0.3))),
                );
                scene.meshes.push(c);
                scene.integrator = integrator;
                scene
            };
            let (with, without) = (build(true), build(false));
            let (a, b) = (
                Accel::build(&with).unwrap(),
                Accel::build(&without).unwrap(),
            );
            assert_eq!(a.primitive_count(), b.primitive_count());
            assert_eq!(a.memory(), b.memory());
            let (ia, ib) = (
                render(&with, &opts(8, 2)).unwrap(),
                render(&without, &opts(8, 2)).unwrap(),
            );
            assert!(ia.image.mean().max_element() > 0.01);
            assert_eq!(ia.image, ib.image, "material {material}, {integrator:?}");
        }
    }
}

/// Radiance along a horizontal line of rays across a coarse (12 x 24) sphere under a delta
/// sun, direct light only, against the analytic Lambertian `ρ E cos θ / π` with `θ` between
/// the sun and the true sphere normal at the hit point. With analytic vertex normals the
/// interpolated normal at a point of a facet *is* the direction from the centre through it,
/// so smooth shading matches to rounding; flat shading is off by the facet angle. Returns
/// (mean, max) relative error.
fn sphere_line_error(smooth: bool) -> (f32, f32) {
    use crate::integrators::{SceneContext, path};
    use crate::sampler::PixelSampler;
    let (rho, e) = (0.5, 2.0);
    let wsun = Vec3::new(0.5, 0.3, 0.8).normalize();
    let scene = sphere_scene(
        uv_sphere(Vec3::ZERO, 1.0, 12, 24, smooth, 0),
        vec![sun(wsun, e)],
        None,
    );
    let ctx = SceneContext::new(&scene).unwrap();
    let (mut sum, mut max, mut n) = (0.0f32, 0.0f32, 0);
    for k in 0..=200 {
        let x = -0.9 + 1.8 * k as f32 / 200.0;
        let ray = Ray {
            origin: Vec3::new(x, 0.13, 5.0),
            dir: -Vec3::Z,
            tmax: f32::INFINITY,
        };
        let hit = ctx
            .accel
            .intersect(&ray)
            .unwrap_or_else(|| panic!("x = {x}: no hit"));
        let cos = (ray.origin + hit.t * ray.dir).normalize().dot(wsun);
        if cos < 0.3 {
            continue; // near the terminator facets are lit or not by their own normal
        }
        let mut sampler = PixelSampler::new(1, k, 0, 0);
        let l = path::radiance(&ctx, ray, &mut sampler, 1, 5, &mut 0).x;
        let expect = rho * e * cos / PI;
        let err = (l - expect).abs() / expect;
        sum += err;
        max = max.max(err);
        n += 1;
    }
    assert!(n > 100, "{n} samples");
    (sum / n as f32, max)
}

#[test]
fn smooth_sphere_follows_analytic_lambertian() {
    let (smooth_mean, smooth_max) = sphere_line_error(true);
    let (flat_mean, flat_max) = sphere_line_error(false);
    eprintln!(
        "sphere line, relative error: smooth mean {smooth_mean:.2e} max {smooth_max:.2e}; \
         flat mean {flat_mean:.2e} max {flat_max:.2e}"
    );
    assert!(smooth_max < 1e-3, "smooth max error {smooth_max}");
    assert!(
        flat_mean > 0.01,
        "flat shading should show facets: {flat_mean}"
    );
    assert!(
        smooth_mean * 50.0 < flat_mean && smooth_max * 20.0 < flat_max,
        "smooth {smooth_mean}/{smooth_max} vs flat {flat_mean}/{flat_max}"
    );
}

/// No light leaks through a surface whose vertex normals are tilted 60° off its geometric
/// normal: a sun 10° *below* the ground (geometric cosine -0.17, shading cosine +0.77)
/// leaves an opaque ground exactly black for both integrators, while a sun 20° above it on
/// the side the normals lean to lights it by the shading cosine.
#[test]
fn tilted_normals_do_not_leak_light() {
    let tilt = 60f32.to_radians();
    let ns = Vec3::new(tilt.sin(), 0.0, tilt.cos());
    let mut ground = card(2.0, 0.0, 0);
    ground.normals = vec![ns; 4];
    let (rho, e) = (0.5, 2.0);
    for integrator in [
        Integrator::Path {
            max_depth: 4,
            rr_depth: 2,
        },
        Integrator::Paper {
            ambient: Some(Vec3::ZERO),
        },
    ] {
        for elevation_deg in [-10f32, 20.0] {
            let el = elevation_deg.to_radians();
            let wsun = Vec3::new(el.cos(), 0.0, el.sin());
            let mut scene = sphere_scene(ground.clone(), vec![sun(wsun, e)], None);
            scene.integrator = integrator;
            // Looking down from the side the normals lean to, so every view is consistent.
            scene.camera.position = Vec3::new(0.8, 0.0, 1.0);
            scene.film = film(12, 12, 2);
            let out = render(&scene, &opts(2, 2)).unwrap();
            if elevation_deg < 0.0 {
                let max = out
                    .image
                    .pixels
                    .iter()
                    .map(|p| p.max_element())
                    .fold(0.0, f32::max);
                assert_eq!(max, 0.0, "{integrator:?}: light leaked through the ground");
            } else {
                let expect = rho * e * ns.dot(wsun) / PI;
                for p in &out.image.pixels {
                    assert!(
                        (p.x - expect).abs() < 1e-4 * expect,
                        "{integrator:?}: {p} vs {expect}"
                    );
                }
            }
        }
    }
}

/// The furnace with a smooth-shaded white sphere (12 x 24, vertex normals) added: the
/// image mean stays within the furnace test's 0.5 % of 1 (dropping inconsistent
/// directions loses at most `(1 - cos α) / 2` per bounce for a normal tilted by α, never
/// adds energy).
#[test]
fn furnace_with_shading_normals() {
    let mut tilted = card(0.6, 0.0, 1);
    for p in &mut tilted.positions {
        *p = Vec3::new(p.x, p.y * 0.6, p.z + p.y * 0.8 + 0.3);
    }
    let scene = Scene {
        camera: camera_at(2.5, 50.0),
        film: film(24, 24, 256),
        integrator: Integrator::Path {
            max_depth: 100,
            rr_depth: 3,
        },
        lights: vec![],
        sky: Some(Sky::Constant(Vec3::ONE)),
        materials: vec![
            diffuse(1.0),
            diffuse_transmission(Vec3::new(0.6, 0.5, 0.9), Vec3::new(0.4, 0.5, 0.1)),
        ],
        meshes: vec![
            card(0.8, -0.3, 0),
            tilted,
            uv_sphere(Vec3::new(-0.25, -0.2, 0.35), 0.35, 12, 24, true, 0),
        ],
        prototypes: Vec::new(),
        instances: Vec::new(),
    };
    let out = render(&scene, &opts(256, 2)).unwrap();
    let m = out.image.mean();
    eprintln!("furnace with a smooth sphere: mean {m}");
    assert!(
        (m - Vec3::ONE).abs().max_element() < 0.005,
        "image mean {m}"
    );
    for p in &out.image.pixels {
        assert!((*p - Vec3::ONE).abs().max_element() < 0.15, "pixel {p}");
    }
}

/// Instances carry vertex normals through the inverse transpose: the shading normal of an
/// instanced smooth sphere equals that of the same sphere flattened into world space with
/// its normals transformed, through rotation, non-uniform scale and a mirror.
#[test]
fn instanced_shading_normals_match_flattened() {
    let sphere = uv_sphere(Vec3::ZERO, 0.5, 8, 16, true, 0);
    let transforms = test_transforms();
    let mut inst = sphere_scene(sphere.clone(), vec![], None);
    inst.meshes = Vec::new();
    inst.prototypes = vec![Prototype {
        name: "sphere".into(),
        meshes: vec![sphere.clone()],
    }];
    inst.instances = transforms
        .iter()
        .map(|&transform| Instance {
            prototype: 0,
            transform,
        })
        .collect();
    let mut flat = inst.clone();
    flat.prototypes = Vec::new();
    flat.instances = Vec::new();
    flat.meshes = transforms
        .iter()
        .map(|&m| {
            let mut out = flatten(&sphere, m);
            let it = m.matrix3.inverse().transpose();
            for n in &mut out.normals {
                *n = (it * glam::Vec3A::from(*n)).into();
            }
            out
        })
        .collect();
    let (a, b) = (Accel::build(&inst).unwrap(), Accel::build(&flat).unwrap());
    let mut hits = 0;
    for i in 0..2000u32 {
        let s = crate::sampler::sobol_2d(i, 5);
        let origin = Vec3::new(s.x * 4.0 - 2.0, s.y * 4.0 - 2.0, 3.0);
        let ray = Ray {
            origin,
            dir: (Vec3::new(s.y - 0.5, s.x - 0.5, 0.0) - origin).normalize(),
            tmax: f32::INFINITY,
        };
        let (Some(ha), Some(hb)) = (a.intersect(&ray), b.intersect(&ray)) else {
            continue;
        };
        let (HitKind::Triangle { prim: pa, bary: ba }, HitKind::Triangle { prim: pb, bary: bb }) =
            (ha.kind, hb.kind)
        else {
            continue;
        };
        if (ha.t - hb.t).abs() > 1e-4 * hb.t {
            continue; // grazing an edge: different triangles
        }
        let (na, nb) = (
            a.shading_normal(pa, ba).unwrap(),
            b.shading_normal(pb, bb).unwrap(),
        );
        assert!(na.dot(nb) > 0.9999, "shading normal {na} vs {nb}");
        // And it is the smooth one: on the outside of the (mirrored or not) sphere.
        let (_, info) = a.surface(pa, ba);
        assert!(na.dot(info.n) > 0.5, "{na} vs geometric {}", info.n);
        hits += 1;
    }
    assert!(hits > 200, "{hits} hits");
}
/// Directions with negative zeros (`-Vec3::Z` is `(-0, -0, -1)`) hit what the same
/// direction with positive zeros hits: obvhs derives the octant and the inverse direction
/// differently for `-0`, which made such rays miss half of a sphere.
#[test]
fn negative_zero_directions_hit() {
    let scene = sphere_scene(uv_sphere(Vec3::ZERO, 1.0, 12, 24, true, 0), vec![], None);
    let a = Accel::build(&scene).unwrap();
    for x in [-0.9f32, -0.5, 0.0, 0.5] {
        for (o, d, plus) in [
            (Vec3::new(x, 0.13, 5.0), -Vec3::Z, Vec3::new(0.0, 0.0, -1.0)),
            (Vec3::new(5.0, 0.13, x), -Vec3::X, Vec3::new(-1.0, 0.0, 0.0)),
        ] {
            let ray = |dir| Ray {
                origin: o,
                dir,
                tmax: f32::INFINITY,
            };
            let (h, h_plus) = (a.intersect(&ray(d)), a.intersect(&ray(plus)));
            assert!(h_plus.is_some());
            assert_eq!(h, h_plus, "{o} {d}");
            assert!(a.occluded(&ray(d)));
        }
    }
}

/// Shading normals keep renders deterministic: a smooth sphere (opaque and
/// transmitting) on a card, under a sun and a sky, renders the same pixels and ray count on
/// 1, 2 and 3 threads.
#[test]
fn smooth_shading_deterministic_across_thread_counts() {
    let mut scene = sphere_scene(
        uv_sphere(Vec3::new(0.0, 0.2, 0.0), 0.7, 12, 24, true, 1),
        vec![sun(Vec3::new(0.4, 0.5, 0.7).normalize(), 3.0)],
        Some(Sky::Constant(Vec3::splat(0.3))),
    );
    scene.meshes.push(card(2.0, -0.8, 0));
    let a = render(&scene, &opts(8, 1)).unwrap();
    assert!(a.image.pixels.iter().all(|p| p.is_finite()));
    assert!(a.image.mean().max_element() > 0.01);
    for threads in [2, 3] {
        let b = render(&scene, &opts(8, threads)).unwrap();
        assert_eq!(a.image, b.image, "{threads} threads");
        assert_eq!(a.stats.rays, b.stats.rays);
    }
}

/// Leaves with vertex normals keep their sides geometric: a leaf whose normals point to its
/// abaxial side (against its winding) renders exactly like one whose normals point to the
/// adaxial side, tilted or not, and untilted abaxial normals like no normals at all; lit
/// from the front and from behind (through-light), the adaxial and abaxial views differ.
#[test]
fn leaf_sides_follow_the_geometric_normal() {
    use lamina_leaf::{LeafMaps, LeafMaterial, LeafParams};
    let maps = LeafMaps {
        front: Some(Texture::constant(Vec4::new(0.05, 0.3, 0.04, 1.0))),
        back: Some(Texture::constant(Vec4::new(0.2, 0.35, 0.15, 1.0))),
        translucency: Some(Texture::constant(Vec4::new(0.1, 0.4, 0.05, 1.0))),
        ..Default::default()
    };
    let leaf = Arc::new(LeafMaterial::new(maps, LeafParams::default()).unwrap());
    let tilt = 25f32.to_radians();
    let ns = Vec3::new(tilt.sin(), 0.0, tilt.cos());
    let render_with = |normals: Vec<Vec3>, sun_z: f32, cam_z: f32| {
        let mut m = card(2.0, 0.0, 0);
        m.normals = normals;
        let mut scene = sphere_scene(
            m,
            vec![sun(Vec3::new(0.3, 0.2, sun_z).normalize(), 3.0)],
            Some(Sky::Constant(Vec3::splat(0.2))),
        );
        scene.materials = vec![Material::Leaf {
            name: "leaf".into(),
            leaf: leaf.clone(),
        }];
        scene.camera.position = Vec3::new(0.3, 0.0, cam_z);
        scene.film = film(12, 12, 4);
        render(&scene, &opts(4, 2)).unwrap().image
    };
    for (sun_z, cam_z) in [(1.0, 1.5), (-1.0, 1.5), (1.0, -1.5)] {
        let up = render_with(vec![ns; 4], sun_z, cam_z);
        assert!(up.mean().max_element() > 1e-3, "black leaf");
        assert_eq!(up, render_with(vec![-ns; 4], sun_z, cam_z));
        assert_eq!(
            render_with(vec![], sun_z, cam_z),
            render_with(vec![-Vec3::Z; 4], sun_z, cam_z)
        );
    }
    let (front, through) = (
        render_with(vec![ns; 4], 1.0, 1.5),
        render_with(vec![ns; 4], -1.0, 1.5),
    );
    assert_ne!(front.mean(), through.mean());
}

/// Tiny prototypes (at most `SMALL_BLAS` primitives, tested without a BVH) answer like
/// the flattened geometry: three crossing cards (two with a half-transparent matte) and
/// one triangle, placed rotated, non-uniformly scaled and mirrored. Closest hit, any hit,
/// and the continuation of every hit ray from its exact hit point skipping the primitive it
/// left (which must find the next surface, never the same one).
#[test]
fn tiny_instanced_prototypes_match_flattened_geometry() {
    let matte = Texture::from_texels(2, 1, vec![Vec4::ZERO, Vec4::ONE], Wrap::Clamp);
    let base = small_canopy_scene();
    let mut meshes: Vec<Mesh> = base.meshes[..3].to_vec();
    meshes[0].material = 2;
    meshes[2].material = 2;
    meshes.push(Mesh {
        positions: vec![
            Vec3::new(-0.5, -0.4, 0.1),
            Vec3::new(0.6, -0.2, -0.1),
            Vec3::new(0.0, 0.7, 0.2),
        ],
        indices: vec![[0, 1, 2]],
        material: 1,
        ..Default::default()
    });
    let mut inst = base.clone();
    inst.materials.push(Material::Diffuse {
        name: "matte".into(),
        reflectance: ColorInput::Constant(Vec3::splat(0.5)),
        alpha: Some(AlphaMask {
            map: matte,
            use_alpha_channel: false,
            cutoff: 0.5,
        }),
    });
    inst.prototypes = vec![Prototype {
        name: "tiny".into(),
        meshes: meshes.clone(),
    }];
    inst.meshes = Vec::new();
    let transforms = test_transforms();
    inst.instances = transforms
        .iter()
        .map(|&transform| Instance {
            prototype: 0,
            transform,
        })
        .collect();
    let mut flat = inst.clone();
    flat.prototypes = Vec::new();
    flat.instances = Vec::new();
    flat.meshes = transforms
        .iter()
        .flat_map(|&m| meshes.iter().map(move |mesh| flatten(mesh, m)))
        .collect();
    let (a, b) = (Accel::build(&inst).unwrap(), Accel::build(&flat).unwrap());
    assert_eq!(a.instance_count(), 3);
    assert_eq!(
        a.primitive_count(),
        4 + 1,
        "3 cards + 1 triangle + the quad light"
    );
    let prim = |h: &crate::Hit| match h.kind {
        HitKind::Triangle { prim, .. } => prim,
        HitKind::Sphere { .. } => crate::accel::PrimRef::NONE,
    };
    let (mut n, mut hits, mut second, mut disagree) = (0, 0, 0, 0);
    for i in 0..4000u32 {
        let s = crate::sampler::sobol_2d(i, 5);
        let q = crate::sampler::sobol_2d(i, 6);
        let origin = Vec3::new(s.x * 4.0 - 2.0, s.y * 4.0 - 2.0, 3.0 - 6.0 * (i % 2) as f32);
        let target = Vec3::new(q.x * 3.0 - 1.5, q.y * 3.0 - 1.5, (q.x - q.y) * 2.0 - 1.0);
        let ray = Ray {
            origin,
            dir: (target - origin).normalize(),
            tmax: f32::INFINITY,
        };
        n += 1;
        let (ha, hb) = (a.intersect(&ray), b.intersect(&ray));
        assert_eq!(a.occluded(&ray), ha.is_some());
        let (Some(ha), Some(hb)) = (ha, hb) else {
            disagree += (ha.is_some() != hb.is_some()) as u32;
            continue;
        };
        if (ha.t - hb.t).abs() >= 1e-4 * hb.t {
            disagree += 1;
            continue;
        }
        hits += 1;
        let (pa, pb) = (prim(&ha), prim(&hb));
        if pa == crate::accel::PrimRef::NONE {
            continue;
        }
        let HitKind::Triangle { bary, .. } = ha.kind else {
            unreachable!()
        };
        let (xa, ia) = a.surface(pa, bary);
        let HitKind::Triangle { bary: bb, .. } = hb.kind else {
            unreachable!()
        };
        let (xb, ib) = b.surface(pb, bb);
        assert!((xa - xb).length() < 1e-4, "position {xa} vs {xb}");
        assert!(ia.n.dot(ib.n) > 0.9999, "normal {} vs {}", ia.n, ib.n);
        // Continue from the exact hit point, skipping the primitive just hit.
        let next = |p: Vec3| Ray {
            origin: p,
            dir: ray.dir,
            tmax: 100.0,
        };
        let (na, nb) = (
            a.intersect_skip(&next(xa), pa),
            b.intersect_skip(&next(xb), pb),
        );
        assert_eq!(a.occluded_skip(&next(xa), pa), na.is_some());
        if let Some(h) = na {
            assert_ne!(prim(&h), pa, "the skipped primitive was hit again");
        }
        match (na, nb) {
            (None, None) => {}
            (Some(na), Some(nb)) if (na.t - nb.t).abs() < 1e-4 * nb.t.max(1e-2) => second += 1,
            _ => disagree += 1,
        }
    }
    eprintln!("{hits} hits, {second} second hits, {disagree} disagree of {n}");
    assert!(hits > n / 8, "{hits} of {n} rays hit");
    assert!(second > n / 40, "{second} of {n} rays hit twice");
    assert!(disagree * 100 < n, "{disagree} of {n} rays disagree");
}
