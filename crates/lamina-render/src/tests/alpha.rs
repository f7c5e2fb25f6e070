//! Alpha mattes in rendered images: camera and shadow rays pass the transparent part of a
//! card, in world space and as a (mirrored) instance.

use super::scenes::*;
use crate::render;
use glam::{Affine3A, Quat, Vec3, Vec4};
use lamina_core::{AlphaMask, ColorInput, Instance, Integrator, Light, Material, Prototype, Scene};
use lamina_leaf::{Texture, Wrap};
use std::f32::consts::PI;

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
        radiometry: Default::default(),
        camera: camera_at(20.0, 4.0), // ±0.7 m at the ground, nearly orthographic
        film: film(40, 8, 4),
        integrator: Integrator::Path {
            max_depth: 1,
            rr_depth: 5,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
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
            radiometry: Default::default(),
            camera: camera_at(20.0, 4.0),
            film: film(40, 8, 4),
            integrator: Integrator::Path {
                max_depth: 1,
                rr_depth: 5,
                light_sampling: Default::default(),
                sky_sampling: Default::default(),
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
