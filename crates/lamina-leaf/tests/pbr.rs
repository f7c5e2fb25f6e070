//! Tests of the glTF metallic-roughness surface [`PbrBsdf`]: energy, sampling against the
//! pdf and against a quadrature of `eval`, reciprocity, limits, two-sidedness and
//! degenerate inputs.

mod common;

use common::*;
use glam::{Vec2, Vec3};
use lamina_leaf::march::Pcg32;
use lamina_leaf::sampling::uniform_sphere;
use lamina_leaf::*;
use std::f64::consts::PI;

fn pbr(base: f32, metallic: f32, roughness: f32, transmission: f32) -> PbrBsdf {
    PbrBsdf {
        base_color: Vec3::splat(base),
        metallic,
        roughness,
        ior: 1.5,
        transmission,
        transmission_color: Vec3::ONE,
    }
}

fn finite(v: Vec3) -> bool {
    v.is_finite()
}

/// `∫ eval(wo, wi) dωi` over the sphere (reflection, transmission) by a midpoint rule in
/// `(θ, φ)` with `n` × `2n` cells, in double precision.
fn quadrature<B: Bsdf>(b: &B, wo: Vec3, n: usize) -> (Vec3, Vec3, f64) {
    let (mut r, mut t) = ([0f64; 3], [0f64; 3]);
    let mut pdf = 0.0f64;
    let dth = PI / n as f64;
    let dph = 2.0 * PI / (2 * n) as f64;
    for i in 0..n {
        let th = (i as f64 + 0.5) * dth;
        let (st, ct) = th.sin_cos();
        let dw = st * dth * dph;
        for j in 0..2 * n {
            let ph = (j as f64 + 0.5) * dph;
            let wi = Vec3::new((st * ph.cos()) as f32, (st * ph.sin()) as f32, ct as f32);
            let f = b.eval(wo, wi);
            let acc = if wi.z * wo.z > 0.0 { &mut r } else { &mut t };
            for c in 0..3 {
                acc[c] += f[c] as f64 * dw;
            }
            pdf += b.pdf(wo, wi) as f64 * dw;
        }
    }
    let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
    (v(r), v(t), pdf)
}

// ---------------------------------------------------------------- 1. energy

#[test]
fn energy_is_conserved_over_the_parameter_grid() {
    let mut worst = (0.0f32, String::new());
    let mut worst_table = (0.0f32, String::new());
    for &theta in &[0.0f32, 30.0, 60.0, 80.0, 89.0] {
        let wo = dir(theta, 20.0);
        for &rough in &[0.05f32, 0.3, 0.7, 1.0] {
            for &metallic in &[0.0f32, 0.5, 1.0] {
                for &base in &[0.0f32, 0.5, 1.0] {
                    for &tr in &[0.0f32, 0.5, 1.0] {
                        for &ior in &[1.5f32, 3.0] {
                            let b = PbrBsdf {
                                ior,
                                ..pbr(base, metallic, rough, tr)
                            };
                            let (r, t) = directional_albedo(&b, wo, 24);
                            let a = (r + t).max_element();
                            assert!(finite(r) && finite(t));
                            if a > worst.0 {
                                worst = (a, format!("{b:?} theta {theta}"));
                            }
                            // The tabulated albedo agrees with the estimate.
                            let tab = b.albedo(wo);
                            let d = (tab - (r + t)).abs().max_element();
                            if d > worst_table.0 {
                                worst_table =
                                    (d, format!("{b:?} theta {theta}: {tab} vs {}", r + t));
                            }
                        }
                    }
                }
            }
        }
    }
    eprintln!(
        "max albedo {} at {}; max |table − MC| {} at {}",
        worst.0, worst.1, worst_table.0, worst_table.1
    );
    assert!(worst.0 <= 1.005, "albedo {} > 1 for {}", worst.0, worst.1);
    assert!(
        worst_table.0 < 0.01,
        "table albedo off by {}",
        worst_table.0
    );
}

#[test]
fn smooth_white_metal_reflects_almost_everything() {
    for &rough in &[0.0f32, 0.05, 0.1] {
        let b = pbr(1.0, 1.0, rough, 0.0);
        let (r, t) = directional_albedo(&b, Vec3::Z, 32);
        eprintln!("white metal roughness {rough}: albedo {r}");
        assert!(r.min_element() > 0.95, "albedo {r}");
        assert!(r.max_element() < 1.005, "albedo {r}");
        assert_eq!(t, Vec3::ZERO);
    }
}

// ---------------------------------------------------------------- 2. sampling

fn sampling_configs() -> Vec<PbrBsdf> {
    vec![
        pbr(0.8, 0.0, 0.5, 0.0),
        pbr(0.5, 0.0, 0.3, 0.5),
        pbr(0.9, 1.0, 0.4, 0.0),
        PbrBsdf {
            base_color: Vec3::new(0.9, 0.4, 0.1),
            metallic: 0.5,
            roughness: 0.7,
            ior: 1.8,
            transmission: 0.6,
            transmission_color: Vec3::new(0.2, 0.8, 0.3),
        },
        pbr(0.2, 0.0, 1.0, 1.0),
    ]
}

#[test]
fn sample_estimate_matches_quadrature_of_eval() {
    let mut worst = 0.0f32;
    let mut worst_pdf = 0.0f64;
    for b in sampling_configs() {
        for &theta in &[0.0f32, 45.0, 75.0, 120.0] {
            let wo = dir(theta, 10.0);
            let (rq, tq, pdf_int) = quadrature(&b, wo, 600);
            let (rs, ts) = directional_albedo(&b, wo, 48);
            let d = (rq - rs).abs().max((tq - ts).abs()).max_element();
            worst = worst.max(d);
            // The pdf integrates to one minus the mass of rejected specular samples.
            let n = 20_000;
            let mut rng = Pcg32::new(5);
            let got = (0..n)
                .filter(|_| {
                    let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                    b.sample(wo, u).is_some()
                })
                .count() as f64
                / n as f64;
            assert!(pdf_int <= 1.0 + 2e-3, "pdf integral {pdf_int}");
            worst_pdf = worst_pdf.max((pdf_int - got).abs());
            assert!(
                (pdf_int - got).abs() < 0.01,
                "{b:?} theta {theta}: pdf integral {pdf_int} vs sampled fraction {got}"
            );
            assert!(
                d < 0.01,
                "{b:?} theta {theta}: quadrature {rq} {tq} vs MC {rs} {ts}"
            );
        }
    }
    eprintln!("max |MC − quadrature| {worst}, max |∫pdf − sampled fraction| {worst_pdf}");
}

#[test]
fn sample_pdf_and_f_equal_pdf_and_eval() {
    let mut rng = Pcg32::new(11);
    for b in sampling_configs() {
        for _ in 0..2000 {
            let wo = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            if let Some(s) = b.sample(wo, u) {
                let p = b.pdf(wo, s.wi);
                assert!(s.pdf > 0.0 && s.pdf.is_finite());
                assert!((s.pdf - p).abs() <= 1e-5 * p.max(1.0), "{} vs {p}", s.pdf);
                let f = b.eval(wo, s.wi);
                assert!((s.f - f).abs().max_element() <= 1e-5 * f.max_element().max(1.0));
                assert!((s.wi.length() - 1.0).abs() < 1e-3);
            }
        }
    }
}

#[test]
fn chi_square_sampling_matches_pdf() {
    let configs = sampling_configs();
    let angles = [0.0f32, 40.0, 80.0, 150.0];
    let tests = configs.len() * angles.len();
    let alpha = sidak(0.01, tests);
    for b in &configs {
        for &theta in &angles {
            let wo = dir(theta, 30.0);
            let c = chi_square(b, wo, 200_000, 3);
            assert!(
                c.p_value > alpha,
                "{b:?} theta {theta}: {c:?} (alpha {alpha})"
            );
            assert!((c.pdf_integral - c.sampled_fraction).abs() < 0.01, "{c:?}");
        }
    }
}

// ---------------------------------------------------------------- 3. reciprocity

#[test]
fn eval_is_reciprocal() {
    let mut rng = Pcg32::new(2);
    let mut worst = 0.0f32;
    for b in sampling_configs() {
        for _ in 0..5000 {
            let wo = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let wi = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            if wo.z.abs() < 1e-3 || wi.z.abs() < 1e-3 {
                continue;
            }
            let a = b.eval(wo, wi) / wi.z.abs();
            let c = b.eval(wi, wo) / wo.z.abs();
            let rel = (a - c).abs().max_element() / a.max(c).max_element().max(1e-3);
            worst = worst.max(rel);
            assert!(rel < 1e-3, "{b:?}: {wo} {wi}: {a} vs {c}");
        }
    }
    eprintln!("max relative reciprocity error {worst}");
}

// ---------------------------------------------------------------- 4. limits

#[test]
fn index_matched_rough_dielectric_is_lambertian() {
    let base = Vec3::new(0.7, 0.3, 0.1);
    let b = PbrBsdf {
        base_color: base,
        metallic: 0.0,
        roughness: 1.0,
        ior: 1.0,
        transmission: 0.0,
        transmission_color: Vec3::ONE,
    };
    let l = Lambertian { reflectance: base };
    let mut rng = Pcg32::new(4);
    for _ in 0..2000 {
        let wo = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        let wi = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        let (x, y) = (b.eval(wo, wi), l.eval(wo, wi));
        assert!((x - y).abs().max_element() < 1e-6, "{x} vs {y}");
        assert!((b.pdf(wo, wi) - l.pdf(wo, wi)).abs() < 1e-6);
    }
    assert_eq!(b.diffuse_albedo(), (base, Vec3::ZERO));
}

#[test]
fn full_transmission_goes_through_with_the_transmission_colour() {
    let tc = Vec3::new(0.2, 0.9, 0.4);
    for &ior in &[1.0f32, 1.5] {
        for &base in &[0.0f32, 1.0] {
            let b = PbrBsdf {
                base_color: Vec3::splat(base),
                metallic: 0.0,
                roughness: 0.6,
                ior,
                transmission: 1.0,
                transmission_color: tc,
            };
            for &theta in &[0.0f32, 50.0, 130.0] {
                let wo = dir(theta, 0.0);
                let (r, t) = directional_albedo(&b, wo, 32);
                // Reflection is only the (grey) specular coat, whatever the base colour.
                assert!((r.x - r.y).abs() < 1e-3 && (r.y - r.z).abs() < 1e-3, "{r}");
                // Transmission carries the transmission colour's hue.
                let ratio = t / tc;
                assert!((ratio.x - ratio.y).abs() < 0.01 && (ratio.y - ratio.z).abs() < 0.01);
                if ior == 1.0 {
                    assert!(r.max_element() < 1e-6, "{r}");
                    assert!((t - tc).abs().max_element() < 0.01, "{t} vs {tc}");
                } else {
                    assert!(ratio.x > 0.85, "transmitted fraction {}", ratio.x);
                }
            }
            let (dr, dt) = b.diffuse_albedo();
            assert_eq!(dr, Vec3::ZERO);
            assert!((dt / tc - dt.x / tc.x).abs().max_element() < 1e-5);
        }
    }
}

#[test]
fn metal_has_no_transmission_and_its_colour_is_the_base_colour() {
    let base = Vec3::new(0.95, 0.64, 0.54);
    let b = PbrBsdf {
        base_color: base,
        metallic: 1.0,
        roughness: 0.1,
        ior: 1.5,
        transmission: 1.0,
        transmission_color: Vec3::ONE,
    };
    let (r, t) = directional_albedo(&b, Vec3::Z, 32);
    assert_eq!(t, Vec3::ZERO);
    assert!((r - base).abs().max_element() < 0.02, "{r} vs {base}");
    assert_eq!(b.diffuse_albedo(), (Vec3::ZERO, Vec3::ZERO));
    // Mirror direction at normal incidence: f ∝ base colour.
    let f = b.eval(Vec3::Z, Vec3::Z);
    assert!((f / f.x - base / base.x).abs().max_element() < 1e-4, "{f}");
    let mut rng = Pcg32::new(9);
    for _ in 0..1000 {
        let wo = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        let wi = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        if wo.z * wi.z < 0.0 {
            assert_eq!(b.eval(wo, wi), Vec3::ZERO);
            assert_eq!(b.pdf(wo, wi), 0.0);
        }
    }
}

#[test]
fn diffuse_albedo_is_the_cosine_average_of_the_diffuse_lobes() {
    // Integrate the diffuse part (eval of the dielectric minus its specular part, obtained
    // with base 0) over wo and wi and compare with diffuse_albedo().
    let b = PbrBsdf {
        base_color: Vec3::new(0.8, 0.5, 0.2),
        metallic: 0.3,
        roughness: 0.5,
        ior: 1.5,
        transmission: 0.4,
        transmission_color: Vec3::new(0.3, 0.6, 0.9),
    };
    let no_diffuse = PbrBsdf {
        base_color: Vec3::ZERO,
        transmission_color: Vec3::ZERO,
        metallic: 0.0,
        ..b
    };
    let spec_only = |wo, wi| no_diffuse.eval(wo, wi) * (1.0 - b.metallic);
    let metal = PbrBsdf { metallic: 1.0, ..b };
    let n = 64;
    let (mut r, mut t) = (Vec3::ZERO, Vec3::ZERO);
    for k in 0..n {
        let mu = (k as f32 + 0.5) / n as f32;
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let (rq, tq, _) = quadrature(
            &FnBsdf(|wo, wi| b.eval(wo, wi) - spec_only(wo, wi) - metal.eval(wo, wi) * b.metallic),
            wo,
            200,
        );
        r += rq * 2.0 * mu / n as f32;
        t += tq * 2.0 * mu / n as f32;
    }
    let (dr, dt) = b.diffuse_albedo();
    eprintln!("diffuse albedo {dr} {dt}, integrated {r} {t}");
    assert!((r - dr).abs().max_element() < 5e-3, "{r} vs {dr}");
    assert!((t - dt).abs().max_element() < 5e-3, "{t} vs {dt}");
}

/// A closure as a [`Bsdf`] (eval only) for [`quadrature`].
struct FnBsdf<F>(F);

impl<F: Fn(Vec3, Vec3) -> Vec3> Bsdf for FnBsdf<F> {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        (self.0)(wo, wi)
    }
    fn sample(&self, _: Vec3, _: Vec3) -> Option<BsdfSample> {
        None
    }
    fn pdf(&self, _: Vec3, _: Vec3) -> f32 {
        0.0
    }
}

// ---------------------------------------------------------------- 5. two-sidedness

#[test]
fn both_faces_are_the_same() {
    let mut rng = Pcg32::new(6);
    for b in sampling_configs() {
        for _ in 0..3000 {
            let wo = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let wi = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let (x, y) = (b.eval(wo, wi), b.eval(-wo, -wi));
            assert!((x - y).abs().max_element() <= 1e-5 * x.max_element().max(1.0));
            let (p, q) = (b.pdf(wo, wi), b.pdf(-wo, -wi));
            assert!((p - q).abs() <= 1e-5 * p.max(1.0));
        }
    }
}

// ---------------------------------------------------------------- 6. degenerate inputs

#[test]
fn degenerate_inputs_stay_finite() {
    let dirs = [
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        Vec3::new(0.6, 0.0, 0.8),
        Vec3::new(0.6, 0.0, -0.8),
        Vec3::new(-0.6, 0.0, 0.8),
        Vec3::new(1.0, 0.0, 1e-7).normalize(),
    ];
    let one = 1.0 - f32::EPSILON;
    let us = [
        Vec3::ZERO,
        Vec3::splat(0.5),
        Vec3::splat(one),
        Vec3::new(0.2, 0.0, one),
        Vec3::new(0.9, one, 0.0),
    ];
    let mut materials = Vec::new();
    for &rough in &[0.0f32, 1e-4, 1.0] {
        for &metallic in &[0.0f32, 1.0] {
            for &col in &[0.0f32, 1.0] {
                for &ior in &[0.0f32, 1.0, 1.5, 1e6] {
                    for &tr in &[0.0f32, 1.0] {
                        materials.push(PbrBsdf {
                            base_color: Vec3::splat(col),
                            metallic,
                            roughness: rough,
                            ior,
                            transmission: tr,
                            transmission_color: Vec3::splat(col),
                        });
                    }
                }
            }
        }
    }
    for b in &materials {
        for &wo in &dirs {
            for &wi in &dirs {
                let f = b.eval(wo, wi);
                let p = b.pdf(wo, wi);
                assert!(finite(f) && f.min_element() >= 0.0, "{b:?} {wo} {wi}: {f}");
                assert!(p.is_finite() && p >= 0.0, "{b:?} {wo} {wi}: {p}");
            }
            for &u in &us {
                if let Some(s) = b.sample(wo, u) {
                    assert!(
                        finite(s.f) && s.pdf.is_finite() && s.pdf > 0.0,
                        "{b:?} {s:?}"
                    );
                    assert!(finite(s.wi));
                }
            }
            let a = b.albedo(wo);
            assert!(finite(a) && a.max_element() <= 1.0 + 1e-3, "{a}");
        }
        let (r, t) = b.diffuse_albedo();
        assert!(finite(r) && finite(t));
        // In-plane wo: nothing.
        assert_eq!(b.eval(Vec3::X, Vec3::Z), Vec3::ZERO);
        assert_eq!(b.pdf(Vec3::X, Vec3::Z), 0.0);
        assert!(b.sample(Vec3::X, Vec3::splat(0.5)).is_none());
    }
}
