//! Tests of the leaf model that can fail: sampling against the pdf (chi-square), weights,
//! energy, symmetry, the diffuse limit, continuity, the ray march against the closed form,
//! parameter validation and the meaning of the maps.

mod common;

use common::*;
use glam::{Vec2, Vec3, Vec4};
use lamina_leaf::analytic::single_scatter;
use lamina_leaf::layers::LayerStack;
use lamina_leaf::march::{Pcg32, single_scatter_marched};
use lamina_leaf::*;

fn material(maps: LeafMaps, params: LeafParams) -> LeafMaterial {
    LeafMaterial::new(maps, params).expect("valid material")
}

fn constant(c: Vec3) -> Option<Texture> {
    Some(Texture::constant(c.extend(1.0)))
}

fn white_maps() -> LeafMaps {
    LeafMaps {
        front: constant(Vec3::ONE),
        back: constant(Vec3::ONE),
        translucency: constant(Vec3::ONE),
        ..Default::default()
    }
}

/// A bump map that is a ramp in `u`: a constant gradient tilting the shading normal by
/// `tilt_deg` toward `-x` (with `bump_scale` 1).
fn ramp_bump(tilt_deg: f32) -> Option<Texture> {
    let slope = tilt_deg.to_radians().tan();
    let w = 64;
    let texels = (0..w * w)
        .map(|i| {
            let x = (i % w) as f32;
            Vec4::splat(slope * x / w as f32)
        })
        .collect();
    Some(Texture::from_texels(
        w as u32,
        w as u32,
        texels,
        Wrap::Clamp,
    ))
}

fn bump_params() -> LeafParams {
    LeafParams {
        bump_scale: 1.0,
        ..Default::default()
    }
}

// ---------------------------------------------------------------- sampling

#[test]
fn chi_square_sampling_matches_pdf() {
    let leaf_default = material(LeafMaps::default(), LeafParams::default()).bsdf(Vec2::splat(0.5));
    let leaf_eq1 = material(
        LeafMaps::default(),
        LeafParams {
            mode: LeafMode::Eq1,
            roughness_adaxial: 0.4,
            ..Default::default()
        },
    )
    .bsdf(Vec2::splat(0.5));
    let bumped = material(
        LeafMaps {
            bump: ramp_bump(30.0),
            ..Default::default()
        },
        bump_params(),
    )
    .bsdf(Vec2::splat(0.5));
    assert!(
        bumped.shading_normal().x < -0.3,
        "{:?}",
        bumped.shading_normal()
    );
    let lambert = Lambertian {
        reflectance: Vec3::new(0.5, 0.4, 0.3),
    };
    let dt = DiffuseTransmission {
        reflectance: Vec3::new(0.3, 0.5, 0.2),
        transmittance: Vec3::new(0.2, 0.3, 0.1),
    };
    let wos = [
        dir(10.0, 30.0),
        dir(60.0, 200.0),
        dir(120.0, 10.0),
        dir(85.0, 90.0),
    ];
    let tests = 3 * wos.len() + 2 * 2;
    let alpha = sidak(0.01, tests);
    let mut failures = Vec::new();
    let mut check = |name: &str, r: ChiSquare| {
        eprintln!("{name}: {r:?}");
        if r.p_value < alpha {
            failures.push(format!(
                "{name}: p = {:.3e} < {alpha:.3e} ({r:?})",
                r.p_value
            ));
        }
        // The pdf integrates to the fraction of samples that come back.
        if (r.pdf_integral - r.sampled_fraction).abs() > 0.01 {
            failures.push(format!(
                "{name}: pdf integral {} vs sampled {}",
                r.pdf_integral, r.sampled_fraction
            ));
        }
    };
    let n = 1_000_000;
    for (k, &wo) in wos.iter().enumerate() {
        check(
            &format!("leaf default wo {wo}"),
            chi_square(&leaf_default, wo, n, 11 + k as u64),
        );
        check(
            &format!("leaf eq1 wo {wo}"),
            chi_square(&leaf_eq1, wo, n, 21 + k as u64),
        );
        check(
            &format!("leaf bump wo {wo}"),
            chi_square(&bumped, wo, n, 31 + k as u64),
        );
    }
    for (k, &wo) in [dir(30.0, 0.0), dir(150.0, 45.0)].iter().enumerate() {
        check(
            &format!("lambert wo {wo}"),
            chi_square(&lambert, wo, n, 41 + k as u64),
        );
        check(
            &format!("diffuse transmission wo {wo}"),
            chi_square(&dt, wo, n, 51 + k as u64),
        );
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn chi_square_detects_a_wrong_pdf() {
    // A sampler that lies about its pdf must fail the test (the test can fail).
    struct Liar(DiffuseTransmission);
    impl Bsdf for Liar {
        fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
            self.0.eval(wo, wi)
        }
        fn sample(&self, wo: Vec3, u: Vec3) -> Option<BsdfSample> {
            self.0.sample(wo, u)
        }
        fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
            // Uniform instead of cosine within each hemisphere.
            let p = self.0.pdf(wo, wi);
            if p > 0.0 { p / (wi.z.abs() * 2.0) } else { 0.0 }
        }
    }
    let liar = Liar(DiffuseTransmission {
        reflectance: Vec3::splat(0.4),
        transmittance: Vec3::splat(0.4),
    });
    let r = chi_square(&liar, dir(20.0, 0.0), 200_000, 7);
    assert!(r.p_value < 1e-6, "{r:?}");
}

#[test]
fn sample_weight_is_eval_over_pdf() {
    let mats = [
        material(LeafMaps::default(), LeafParams::default()),
        material(
            LeafMaps {
                bump: ramp_bump(40.0),
                ..white_maps()
            },
            bump_params(),
        ),
        material(
            LeafMaps::default(),
            LeafParams {
                mode: LeafMode::Eq1,
                ..Default::default()
            },
        ),
    ];
    let mut rng = Pcg32::new(3);
    for m in &mats {
        let b = m.bsdf(Vec2::splat(0.37));
        for _ in 0..20_000 {
            let wo = sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            if let Some(s) = b.sample(wo, u) {
                let f = b.eval(wo, s.wi);
                let p = b.pdf(wo, s.wi);
                assert!((s.f - f).abs().max_element() <= 1e-6 * (1.0 + f.max_element()));
                assert!((s.pdf - p).abs() <= 1e-5 * p, "{} vs {p}", s.pdf);
                let w = s.weight();
                assert!(w.is_finite() && w.min_element() >= 0.0, "{w}");
                assert!((w - f / p).abs().max_element() <= 1e-4 * (1.0 + w.max_element()));
            }
        }
    }
}

// ---------------------------------------------------------------- energy

#[test]
fn energy_white_maps_every_incidence() {
    for mode in [LeafMode::Layered, LeafMode::Eq1, LeafMode::Diffuse] {
        for params in [
            LeafParams {
                mode,
                ..Default::default()
            },
            LeafParams {
                mode,
                roughness_adaxial: 0.6,
                roughness_abaxial: 1.0,
                thickness_mm: 0.1,
                ..Default::default()
            },
        ] {
            let m = material(white_maps(), params);
            let b = m.bsdf(Vec2::splat(0.5));
            let mut worst = 0.0f32;
            for k in 0..360 {
                // Every 0.5 degrees from the adaxial pole over the abaxial one.
                let theta = 0.25 + k as f32 * 0.5;
                if (theta - 90.0).abs() < 0.2 {
                    continue;
                }
                let wo = dir(theta, 17.0);
                let (r, t) = directional_albedo(&b, wo, 24);
                let sum = (r + t).max_element();
                worst = worst.max(sum);
                assert!(sum <= 1.0, "{mode:?} theta {theta}: R {r} + T {t} = {sum}");
            }
            eprintln!("{mode:?}: worst R + T = {worst}");
            assert!(worst > 0.5, "white maps should be bright ({worst})");
        }
    }
}

#[test]
fn physical_layers_conserve_energy_without_maps() {
    // Pure layer model (no maps): the raw physics is below 1 too, with a clear margin.
    let m = material(LeafMaps::default(), LeafParams::default());
    let b = m.bsdf(Vec2::splat(0.5));
    for theta in [0.0f32, 30.0, 60.0, 85.0, 120.0, 170.0] {
        let (r, t) = directional_albedo(&b, dir(theta, 0.0), 24);
        assert!((r + t).max_element() < 0.6, "{theta}: {r} {t}");
    }
}

// ---------------------------------------------------------------- symmetry

#[test]
fn diffuse_transmission_is_symmetric() {
    let m = material(LeafMaps::default(), LeafParams::default());
    let b = m.bsdf(Vec2::splat(0.5));
    // Reciprocity of the transmission lobe: f(wo, wi) = f(wi, wo).
    let mut rng = Pcg32::new(9);
    for _ in 0..2000 {
        let a = sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        let c = sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        if a.z * c.z >= 0.0 || a.z.abs() < 0.2 || c.z.abs() < 0.2 {
            continue;
        }
        let f1 = b.eval(a, c) / c.z.abs();
        let f2 = b.eval(c, a) / a.z.abs();
        assert!(
            (f1 - f2).abs().max_element() <= 1e-4 * f1.max_element().max(1e-6),
            "{f1} {f2}"
        );
    }
    // Through-light is the same from both sides: transmitted albedo from above equals that
    // from below, at every angle.
    for theta in [0.0f32, 40.0, 75.0] {
        let (_, t_top) = directional_albedo(&b, dir(theta, 0.0), 32);
        let (_, t_bot) = directional_albedo(&b, dir(180.0 - theta, 0.0), 32);
        assert!(
            (t_top - t_bot).abs().max_element() <= 0.01 * t_top.max_element(),
            "{theta}: {t_top} vs {t_bot}"
        );
    }
}

// ---------------------------------------------------------------- diffuse limit

#[test]
fn diffuse_limit_is_exactly_lambertian_r_plus_t() {
    for (r, t) in [
        (Vec3::new(0.12, 0.35, 0.08), Vec3::new(0.1, 0.4, 0.05)),
        // R + T = 1: a non-absorbing leaf.
        (Vec3::new(0.5, 0.625, 0.25), Vec3::new(0.5, 0.375, 0.75)),
    ] {
        let params = LeafParams {
            mode: LeafMode::Diffuse,
            specular: 0.0,
            ..Default::default()
        };
        let maps = LeafMaps {
            front: constant(r),
            back: constant(r),
            translucency: constant(t),
            ..Default::default()
        };
        // `constant` holds linear values (no sRGB decoding).
        let b = material(maps, params).bsdf(Vec2::new(0.3, 0.8));
        let reference = DiffuseTransmission {
            reflectance: r,
            transmittance: t,
        };
        let mut rng = Pcg32::new(5);
        for _ in 0..10_000 {
            let wo = sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let wi = sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let (a, e) = (b.eval(wo, wi), reference.eval(wo, wi));
            assert!(
                (a - e).abs().max_element() <= 1e-6 * (1.0 + e.max_element()),
                "{a} {e}"
            );
            let (pa, pe) = (b.pdf(wo, wi), reference.pdf(wo, wi));
            assert!((pa - pe).abs() <= 1e-5 * (1.0 + pe), "{pa} {pe}");
            let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let (sa, se) = (b.sample(wo, u), reference.sample(wo, u));
            assert_eq!(sa.is_some(), se.is_some());
            if let (Some(sa), Some(se)) = (sa, se) {
                assert!(
                    (sa.wi - se.wi).length() < 1e-6
                        && (sa.weight() - se.weight()).abs().max_element() < 1e-5
                );
            }
        }
        let (ra, ta) = b.diffuse_albedo();
        assert!((ra - r).abs().max_element() < 1e-6 && (ta - t).abs().max_element() < 1e-6);
    }
}

// ---------------------------------------------------------------- continuity

fn orbit_steps(b: &LeafBsdf, wo: Vec3, axis_phi: f32) -> (f32, f32, f32) {
    // Light orbiting the leaf in a great circle through the poles, 0.5 degree steps.
    let mut prev: Option<Vec3> = None;
    let (mut max_step, mut peak, mut near_plane) = (0.0f32, 0.0f32, 0.0f32);
    for k in 0..=720 {
        let a = (k as f32 * 0.5 + 0.25).to_radians();
        let (s, c) = a.sin_cos();
        let wi = Vec3::new(s * axis_phi.cos(), s * axis_phi.sin(), c);
        let f = b.eval(wo, wi);
        peak = peak.max(f.max_element());
        if wi.z.abs() < 0.01 {
            near_plane = near_plane.max(f.max_element());
        }
        if let Some(p) = prev {
            max_step = max_step.max((f - p).abs().max_element());
        }
        prev = Some(f);
    }
    (max_step, peak, near_plane)
}

#[test]
fn orbiting_light_changes_value_smoothly() {
    let cases = [
        (
            "flat, no specular",
            LeafMaps::default(),
            LeafParams {
                specular: 0.0,
                ..Default::default()
            },
            0.05,
        ),
        ("flat", LeafMaps::default(), LeafParams::default(), 0.15),
        (
            "bump 40 deg, no specular",
            LeafMaps {
                bump: ramp_bump(40.0),
                ..Default::default()
            },
            LeafParams {
                specular: 0.0,
                ..bump_params()
            },
            0.05,
        ),
        (
            "bump 60 deg",
            LeafMaps {
                bump: ramp_bump(60.0),
                ..Default::default()
            },
            bump_params(),
            0.15,
        ),
        (
            "bump 60 deg, eq1",
            LeafMaps {
                bump: ramp_bump(60.0),
                ..Default::default()
            },
            LeafParams {
                mode: LeafMode::Eq1,
                ..bump_params()
            },
            0.15,
        ),
    ];
    for (name, maps, params, bound) in cases {
        let b = material(maps, params).bsdf(Vec2::splat(0.5));
        for wo in [
            dir(20.0, 10.0),
            dir(70.0, 180.0),
            dir(130.0, 60.0),
            dir(95.0, 0.0),
        ] {
            for axis in [0.0f32, 90.0, 200.0] {
                let (step, peak, near) = orbit_steps(&b, wo, axis.to_radians());
                assert!(peak > 0.0);
                assert!(
                    step <= bound * peak,
                    "{name}, wo {wo}, axis {axis}: step {step} vs peak {peak}"
                );
                assert!(
                    near <= 0.02 * peak,
                    "{name}, wo {wo}: {near} at the plane (peak {peak})"
                );
            }
        }
    }
}

#[test]
fn continuity_test_catches_a_naive_bump() {
    // The naive alternative (Lambert with the shading cosine, sides by the geometric normal)
    // jumps at the plane; the orbit test above would reject it.
    struct Naive(Vec3);
    impl Bsdf for Naive {
        fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
            let n = if wi.z > 0.0 { self.0 } else { -self.0 };
            let c = wi.dot(n).max(0.0);
            let a = if wo.z * wi.z > 0.0 { 0.3 } else { 0.2 };
            Vec3::splat(a * c / std::f32::consts::PI)
        }
        fn sample(&self, _: Vec3, _: Vec3) -> Option<BsdfSample> {
            None
        }
        fn pdf(&self, _: Vec3, _: Vec3) -> f32 {
            0.0
        }
    }
    let naive = Naive(Vec3::new(-0.64, 0.0, 0.77));
    let mut prev: Option<f32> = None;
    let mut max_step = 0.0f32;
    let mut peak = 0.0f32;
    for k in 0..=720 {
        let a = (k as f32 * 0.5 + 0.25).to_radians();
        let f = naive.eval(dir(20.0, 0.0), Vec3::new(a.sin(), 0.0, a.cos()));
        peak = peak.max(f.x);
        if let Some(p) = prev {
            max_step = max_step.max((f.x - p).abs());
        }
        prev = Some(f.x);
    }
    assert!(max_step > 0.05 * peak);
}

// ---------------------------------------------------------------- march vs closed form

#[test]
fn march_converges_to_analytic() {
    // Distinct indices in every layer (refraction at every border), scattering in every
    // layer, optical depths of the blade up to about 9 along the refracted rays.
    let base = LeafParams {
        extinction_strength: 0.5,
        thickness_variation: 0.0,
        upper: LayerParams {
            fraction: 0.2,
            ior: 1.52,
            absorption: Vec3::new(0.5, 0.3, 1.0),
            scattering: Vec3::new(4.0, 4.0, 4.0),
        },
        mesophyll: LayerParams {
            fraction: 0.6,
            ior: 1.36,
            absorption: Vec3::new(4.0, 1.5, 8.0),
            scattering: Vec3::new(12.0, 14.0, 10.0),
        },
        lower: LayerParams {
            fraction: 0.2,
            ior: 1.45,
            absorption: Vec3::new(0.3, 0.3, 0.6),
            scattering: Vec3::new(6.0, 6.0, 6.0),
        },
        phase_g: 0.4,
        ..Default::default()
    };
    const SAMPLES: u32 = 100_000;
    let t0 = std::time::Instant::now();
    let mut rng = Pcg32::new(2024);
    let mut failures = Vec::new();
    let mut worst = 0.0f32;
    let mut checked = 0;
    for thickness in [0.1f32, 0.25, 0.5] {
        for extinction in [0.2f32, 0.8] {
            let p = LeafParams {
                thickness_mm: thickness,
                ..base
            };
            let stack = LayerStack::at_texel(&p, 0.5, extinction);
            for ti in [0.0f32, 35.0, 70.0, 85.0] {
                for to in [5.0f32, 50.0, 80.0] {
                    for phi in [0.0f32, 135.0] {
                        for (light_below, view_below) in
                            [(false, false), (false, true), (true, true)]
                        {
                            let mut wi = dir(ti, 0.0);
                            let mut wo = dir(to, phi);
                            if light_below {
                                wi.z = -wi.z;
                            }
                            if view_below {
                                wo.z = -wo.z;
                            }
                            let a = single_scatter(&stack, wo, wi);
                            let m = single_scatter_marched(&stack, wo, wi, SAMPLES, &mut rng);
                            for c in 0..3 {
                                let rel = (m[c] - a[c]).abs() / a[c].max(1e-30);
                                worst = worst.max(rel);
                                checked += 1;
                                if rel >= 0.01 {
                                    failures.push(format!(
                                        "d {thickness} e {extinction} ti {ti} to {to} phi {phi} \
                                         below {light_below}/{view_below} ch {c}: march {} analytic {}",
                                        m[c], a[c]
                                    ));
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    eprintln!(
        "march vs analytic: worst relative difference {worst:.2e} over {checked} values, {:?}",
        t0.elapsed()
    );
    assert!(
        failures.is_empty(),
        "{} failures: {failures:#?}",
        failures.len()
    );
    assert!(checked > 1000);
}

#[test]
fn single_scattering_is_reciprocal() {
    let stack = LayerStack::at_texel(&LeafParams::default(), 0.7, 0.3);
    for (a, b) in [
        (dir(10.0, 0.0), dir(60.0, 90.0)),
        (dir(30.0, 0.0), dir(150.0, 30.0)),
        (dir(100.0, 0.0), dir(170.0, 200.0)),
    ] {
        let f1 = single_scatter(&stack, a, b);
        let f2 = single_scatter(&stack, b, a);
        assert!(
            (f1 - f2).abs().max_element() <= 1e-5 * f1.max_element(),
            "{f1} {f2}"
        );
    }
}

// ---------------------------------------------------------------- parameters

#[test]
fn bad_parameters_are_rejected_naming_the_field() {
    let d = LeafParams::default();
    let cases: Vec<(LeafParams, &str)> = vec![
        (
            LeafParams {
                thickness_mm: f32::NAN,
                ..d
            },
            "thickness_mm",
        ),
        (
            LeafParams {
                thickness_mm: -0.1,
                ..d
            },
            "thickness_mm",
        ),
        (
            LeafParams {
                thickness_mm: 0.0,
                ..d
            },
            "thickness_mm",
        ),
        (LeafParams { phase_g: 1.0, ..d }, "phase_g"),
        (
            LeafParams {
                roughness_adaxial: 0.0,
                ..d
            },
            "roughness_adaxial",
        ),
        (
            LeafParams {
                roughness_abaxial: 1.5,
                ..d
            },
            "roughness_abaxial",
        ),
        (
            LeafParams {
                roughness_abaxial: f32::NAN,
                ..d
            },
            "roughness_abaxial",
        ),
        (
            LeafParams {
                blend_width_deg: 0.0,
                ..d
            },
            "blend_width_deg",
        ),
        (
            LeafParams {
                specular: -1.0,
                ..d
            },
            "specular",
        ),
        (
            LeafParams {
                extinction_strength: 2.0,
                ..d
            },
            "extinction_strength",
        ),
        (
            LeafParams {
                mesophyll: LayerParams {
                    ior: 0.9,
                    ..d.mesophyll
                },
                ..d
            },
            "mesophyll.ior",
        ),
        (
            LeafParams {
                upper: LayerParams {
                    absorption: Vec3::new(1.0, -1.0, 0.0),
                    ..d.upper
                },
                ..d
            },
            "upper.absorption",
        ),
        (
            LeafParams {
                lower: LayerParams {
                    scattering: Vec3::new(1.0, f32::NAN, 0.0),
                    ..d.lower
                },
                ..d
            },
            "lower.scattering",
        ),
        (
            LeafParams {
                upper: LayerParams {
                    fraction: 0.3,
                    ..d.upper
                },
                ..d
            },
            "fraction",
        ),
    ];
    for (p, field) in cases {
        let err = p.validate().expect_err(field);
        let msg = err.to_string();
        assert!(msg.contains(field), "{msg}");
        assert!(msg.contains("must"), "{msg}");
        assert!(LeafMaterial::new(LeafMaps::default(), p).is_err());
    }
    assert!(d.validate().is_ok());
}

#[test]
fn descriptions_parse_and_reject_unknown_keys() {
    let text = r#"
        [maps]
        front = "front.png"
        wrap = "clamp"
        [params]
        thickness_mm = 0.3
        mode = "eq1"
        [params.mesophyll]
        fraction = 0.7
        ior = 1.4
        absorption = [10.0, 3.0, 40.0]
        scattering = [5.0, 5.0, 5.0]
    "#;
    let d: LeafDescription = toml::from_str(text).unwrap();
    assert_eq!(d.params.thickness_mm, 0.3);
    assert_eq!(d.params.mode, LeafMode::Eq1);
    assert_eq!(d.maps.wrap, Wrap::Clamp);
    assert_eq!(d.params.upper, LeafParams::default().upper);
    let bad = "[params]\nthicknes_mm = 0.3\n";
    let e = toml::from_str::<LeafDescription>(bad)
        .unwrap_err()
        .to_string();
    assert!(e.contains("thicknes_mm"), "{e}");
    let round = toml::to_string(&d).unwrap();
    assert_eq!(toml::from_str::<LeafDescription>(&round).unwrap(), d);
}

#[test]
fn missing_map_file_names_the_map_and_the_file() {
    let d = LeafDescription {
        maps: LeafMapPaths {
            extinction: Some("no/such/extinction.png".into()),
            ..Default::default()
        },
        ..Default::default()
    };
    let e = LeafMaterial::load(&d, std::path::Path::new("/tmp"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("extinction") && e.contains("no/such/extinction.png"),
        "{e}"
    );
}

// ---------------------------------------------------------------- maps and defaults

#[test]
fn default_leaf_is_a_believable_green_leaf() {
    let m = material(LeafMaps::default(), LeafParams::default());
    let b = m.bsdf(Vec2::splat(0.5));
    let (r, t) = directional_albedo(&b, Vec3::Z, 48);
    eprintln!("normal incidence: R {r} T {t}");
    // LEAF_MODEL.md: R ~5-15 %, T ~5-20 % in the visible, peaking in the green.
    assert!(r.y > 0.05 && r.y < 0.18, "{r}");
    assert!(t.y > 0.05 && t.y < 0.2, "{t}");
    assert!(r.y > r.x && r.y > r.z && t.y > t.x && t.y > t.z);
    // Yellow-green through-light: red above blue.
    assert!(t.x > t.z);
    // The lower side is paler (reflects more) than the upper one.
    let [af, ab, _] = m.physical_albedos();
    assert!(ab.y > af.y);
}

#[test]
fn texture_colour_is_the_white_sky_albedo() {
    // A nominal texel under diffuse light shows the photo's colour (specular excluded).
    let c = Vec3::new(0.08, 0.2, 0.05);
    let m = material(
        LeafMaps {
            front: constant(c),
            ..Default::default()
        },
        LeafParams {
            specular: 0.0,
            ..Default::default()
        },
    );
    let b = m.bsdf(Vec2::splat(0.5));
    // White-sky albedo: cosine-weighted mean of the directional albedo over incidence.
    let n = 32;
    let mut a = Vec3::ZERO;
    for k in 0..n {
        let mu = (k as f32 + 0.5) / n as f32;
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let (r, _) = directional_albedo(&b, wo, 32);
        a += r * 2.0 * mu / n as f32;
    }
    assert!(
        (a - c).abs().max_element() < 0.02 * c.max_element() + 1e-3,
        "{a} vs {c}"
    );
    // Derived maps: back paler, translucency greener than red and red above blue.
    let [_, back, trans] = m.map_colours(Vec2::splat(0.5));
    assert!(back.min_element() > c.min_element());
    assert!(trans.y > trans.x && trans.x > trans.z, "{trans}");
}

#[test]
fn thicker_and_darker_texels_transmit_less() {
    let w = 2;
    let tex = |a: f32, b: f32| {
        Some(Texture::from_texels(
            w,
            1,
            vec![Vec4::splat(a), Vec4::splat(b)],
            Wrap::Clamp,
        ))
    };
    let m = material(
        LeafMaps {
            thickness: tex(0.1, 0.9),
            extinction: tex(0.1, 0.9),
            ..Default::default()
        },
        LeafParams::default(),
    );
    let thin = m.bsdf(Vec2::new(0.25, 0.5));
    let thick = m.bsdf(Vec2::new(0.75, 0.5));
    let (_, t_thin) = thin.diffuse_albedo();
    let (_, t_thick) = thick.diffuse_albedo();
    assert!(t_thick.y < 0.7 * t_thin.y, "{t_thin} {t_thick}");
    let wo = dir(20.0, 0.0);
    let wi = dir(160.0, 0.0);
    assert!(thick.eval(wo, wi).y < thin.eval(wo, wi).y);
}

#[test]
fn alpha_is_two_state() {
    let tex = Texture::from_texels(
        2,
        1,
        vec![Vec4::new(0.2, 0.2, 0.2, 1.0), Vec4::new(0.9, 0.9, 0.9, 1.0)],
        Wrap::Clamp,
    );
    let m = material(
        LeafMaps {
            alpha: Some(tex),
            ..Default::default()
        },
        LeafParams::default(),
    );
    assert!(!m.opaque(Vec2::new(0.1, 0.5)));
    assert!(m.opaque(Vec2::new(0.9, 0.5)));
    assert!(material(LeafMaps::default(), LeafParams::default()).opaque(Vec2::ZERO));
}

#[test]
fn material_is_send_sync_and_bsdf_is_copy() {
    fn check<T: Send + Sync>() {}
    fn copy<T: Copy>() {}
    check::<LeafMaterial>();
    copy::<LeafBsdf>();
}

#[test]
fn loads_png_16_bit_png_and_exr_maps_of_different_sizes() {
    let dir = std::env::temp_dir().join(format!("lamina-leaf-maps-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // 8-bit sRGB front photo, 4x2: sRGB 128 decodes to linear 0.2158.
    image::RgbImage::from_pixel(4, 2, image::Rgb([128, 128, 128]))
        .save(dir.join("front.png"))
        .unwrap();
    // 16-bit grey thickness map, 3x3, linear.
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(3, 3, image::Luma([49151]))
        .save(dir.join("thickness.png"))
        .unwrap();
    // Float EXR extinction map, 5x1, linear.
    image::Rgb32FImage::from_pixel(5, 1, image::Rgb([0.25, 0.25, 0.25]))
        .save(dir.join("extinction.exr"))
        .unwrap();
    let toml_text = r#"
        [maps]
        front = "front.png"
        thickness = "thickness.png"
        extinction = "extinction.exr"
        wrap = "clamp"
    "#;
    std::fs::write(dir.join("leaf.toml"), toml_text).unwrap();
    let desc = LeafDescription::from_toml_file(&dir.join("leaf.toml")).unwrap();
    let t0 = std::time::Instant::now();
    let m = LeafMaterial::load(&desc, &dir).unwrap();
    eprintln!("LeafMaterial::load with maps: {:?}", t0.elapsed());
    let maps = m.maps();
    let uv = Vec2::new(0.4, 0.6);
    assert!((maps.front.as_ref().unwrap().rgb(uv).x - 0.2158).abs() < 1e-3);
    assert!((maps.thickness.as_ref().unwrap().scalar(uv) - 0.75).abs() < 1e-3);
    assert!((maps.extinction.as_ref().unwrap().scalar(uv) - 0.25).abs() < 1e-6);
    assert_eq!(maps.front.as_ref().unwrap().wrap, Wrap::Clamp);
    // The thickness map thickens the blade: the texel's stack is 1.25x nominal.
    let b = m.bsdf(uv);
    let d: f32 = b.stack().layers.iter().map(|l| l.d).sum();
    assert!((d - 0.25 * 1.25).abs() < 1e-3, "{d}");
    std::fs::remove_dir_all(&dir).ok();
}
