//! Lights through the renderer: quad, sphere and point lights against closed-form irradiance,
//! and the importance-sampled image sky against the constant one.

use super::scenes::*;
use crate::render;
use glam::{Vec3, Vec4};
use lamina_core::{Camera, Integrator, Light, Scene, Sky};
use lamina_leaf::{Texture, Wrap};
use std::f32::consts::PI;

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
            radiometry: Default::default(),
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
                light_sampling: Default::default(),
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

/// (f, in the renderer) An image sky of constant radiance renders like the constant sky: the
/// importance sampling is unbiased.
#[test]
fn image_sky_furnace() {
    let tex = Texture::from_texels(8, 4, vec![Vec4::new(0.5, 0.5, 0.5, 1.0); 32], Wrap::Repeat);
    let scene = Scene {
        radiometry: Default::default(),
        camera: camera_at(2.0, 40.0),
        film: film(12, 12, 32),
        integrator: Integrator::Path {
            max_depth: 20,
            rr_depth: 3,
            light_sampling: Default::default(),
        },
        lights: vec![],
        sky: Some(Sky::Image {
            map: tex,
            scale: 2.0,
            rotation_deg: 10.0,
            spectral: None,
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

/// `light_sampling = "one"` draws one light per vertex by estimated power and divides by
/// its probability, and BSDF samples that reach a light are weighted against that reduced
/// density: the small canopy (a sun disc, a quad, a sphere, a point light and a sky, with
/// light through the leaves) renders the same image as with every light sampled, with
/// fewer rays. The image means agree within 0.3 % per channel (seed-to-seed noise 0.05 %),
/// and 8 x 6 block means within their noise (standard errors from two seeds per mode).
/// Leaving the pick probability out of the MIS weight of BSDF samples that escape to the
/// sky fails it (image mean 0.9 % low), or of those that hit an emitter (4 % low).
#[test]
fn one_light_per_vertex_renders_the_same_image() {
    let mut scene = super::scenes::small_canopy_scene();
    let run = |scene: &Scene, seed: u64| {
        let o = crate::RenderOptions {
            seed,
            ..opts(1024, 2)
        };
        render(scene, &o).unwrap()
    };
    let all = [run(&scene, 7), run(&scene, 8)];
    scene.integrator = Integrator::Path {
        max_depth: 6,
        rr_depth: 2,
        light_sampling: lamina_core::LightSampling::One,
    };
    let one = [run(&scene, 7), run(&scene, 8)];
    assert!(
        (one[0].stats.rays as f64) < 0.8 * all[0].stats.rays as f64,
        "rays: one {} vs all {}",
        one[0].stats.rays,
        all[0].stats.rays
    );
    // Block means over 8 x 6 blocks of the two-seed mean image, and the variance of each
    // from its pixels' seed-to-seed differences (pixels are nearly independent; the
    // Gaussian filter's overlap makes this a slight underestimate, covered by the margin).
    let (w, h) = (all[0].image.width as usize, all[0].image.height as usize);
    let block_stats = |r: &[crate::RenderOutput; 2]| -> Vec<(Vec3, Vec3)> {
        let mut b = vec![(Vec3::ZERO, Vec3::ZERO); 48];
        let n = (w * h) as f32 / 48.0;
        for y in 0..h {
            for x in 0..w {
                let (p0, p1) = (r[0].image.pixels[y * w + x], r[1].image.pixels[y * w + x]);
                let k = (y * 6 / h) * 8 + x * 8 / w;
                b[k].0 += (p0 + p1) * 0.5 / n;
                b[k].1 += (p0 - p1) * (p0 - p1) / 4.0 / (n * n);
            }
        }
        b
    };
    let mean = |r: &[crate::RenderOutput; 2]| (r[0].image.mean() + r[1].image.mean()) * 0.5;
    let (ma, mo) = (mean(&all), mean(&one));
    let rel = ((mo - ma) / ma).abs().max_element();
    assert!(rel < 0.003, "image means: one {mo} vs all {ma}");
    let (ba, bo) = (block_stats(&all), block_stats(&one));
    let (mut worst, mut sum_z2) = (0.0f32, 0.0f32);
    for k in 0..48 {
        for c in 0..3 {
            let sd = (ba[k].1[c] + bo[k].1[c]).sqrt();
            let z = (bo[k].0[c] - ba[k].0[c]) / (sd + 1e-4 * ma[c]);
            worst = worst.max(z.abs());
            sum_z2 += z * z;
        }
    }
    // Unbiased: the z-scores are standard-normal-like (light picks of probability ~1 % make
    // the tails heavier than Gaussian, hence the wide bound on the largest).
    let rms_z = (sum_z2 / 144.0).sqrt();
    assert!(
        rms_z < 1.5 && worst < 6.0,
        "block differences: rms {rms_z}, largest {worst} standard deviations"
    );
}
