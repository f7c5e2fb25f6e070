//! The integrators (path and paper) against closed forms: a Lambertian card under the sun,
//! and the furnace (white surfaces in a white sky stay white).

use super::scenes::*;
use crate::render;
use glam::Vec3;
use lamina_core::{Integrator, Light, Scene, Sky};
use std::f32::consts::PI;

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
                    light_sampling: Default::default(),
                    sky_sampling: Default::default(),
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
                            radiometry: Default::default(),
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
/// The furnace scene of [`furnace_is_energy_conserving`].
pub(super) fn furnace_scene() -> Scene {
    let mut tilted = card(0.6, 0.0, 1);
    for p in &mut tilted.positions {
        *p = Vec3::new(p.x, p.y * 0.6, p.z + p.y * 0.8 + 0.3);
    }
    let mut upright = card(0.5, 0.0, 2);
    for p in &mut upright.positions {
        *p = Vec3::new(p.z - 0.2, p.y, p.x);
    }
    Scene {
        radiometry: Default::default(),
        camera: camera_at(2.5, 50.0),
        film: film(24, 24, 256),
        integrator: Integrator::Path {
            max_depth: 100,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
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
    }
}

#[test]
fn furnace_is_energy_conserving() {
    let scene = furnace_scene();
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

/// `max_depth = 0`: camera rays see the sky and nothing else lit (surfaces that emit
/// nothing stay black), so the furnace's pixels are the share of their samples that
/// escape: exactly 1 on open sky, exactly 0 where a card covers the whole pixel, between
/// at edges; with depth 1 the same cards are lit.
#[test]
fn depth_zero_sees_only_the_sky() {
    let mut scene = furnace_scene();
    let Integrator::Path { max_depth, .. } = &mut scene.integrator else {
        unreachable!()
    };
    *max_depth = 0;
    let out = render(&scene, &opts(16, 2)).unwrap();
    let px = &out.image.pixels;
    assert!(
        px.iter()
            .all(|p| p.x == p.y && p.y == p.z && (0.0..=1.0).contains(&p.x))
    );
    let (sky, covered) = (
        px.iter().filter(|p| p.x == 1.0).count(),
        px.iter().filter(|p| p.x == 0.0).count(),
    );
    assert!(
        sky > px.len() / 10 && covered > px.len() / 10,
        "{sky} sky, {covered} black of {}",
        px.len()
    );
    let Integrator::Path { max_depth, .. } = &mut scene.integrator else {
        unreachable!()
    };
    *max_depth = 1;
    let lit = render(&scene, &opts(16, 2)).unwrap();
    assert!(lit.image.mean().x > out.image.mean().x + 0.1);
}

/// The furnace in spectral bands: white stays white in every band (R = 1, R + T = 1 go
/// through the linear basis unchanged), so every pixel converges to the sky's band value;
/// also for a band weighted by a response curve.
#[test]
fn furnace_in_bands_is_energy_conserving() {
    use lamina_leaf::spectrum::bands::{Band, BandBasis, Response};
    let band = |name: &str, lo: f32, hi: f32| Band::flat(name, lo, hi);
    // The NIR band by a (triangular) response curve.
    let nir_response = Response::parse("780 0\n840 1\n900 0\n").unwrap();
    let (b, g, nir) = (
        band("b", 450.0, 520.0),
        band("g", 540.0, 570.0),
        Band::with_response("nir", nir_response),
    );
    let scene = crate::bands::band_scene(&furnace_scene(), [&b, &g, &nir]).unwrap();
    let sky = BandBasis::new([&b, &g, &nir]).emission(Vec3::ONE);
    let out = render(&scene, &opts(256, 2)).unwrap();
    let m = out.image.mean() / sky;
    assert!(
        (m - Vec3::ONE).abs().max_element() < 0.005,
        "image mean / sky {m} (sky {sky})"
    );
}
