//! Helpers shared by the integration tests: a chi-square goodness-of-fit test for BSDF
//! sampling (after pbrt-v4's and Mitsuba 3's), and numerical integration.
#![allow(dead_code)]

use glam::{Vec2, Vec3};
use lamina_leaf::Bsdf;
use lamina_leaf::march::Pcg32;
use std::f64::consts::PI;

/// Regularised upper incomplete gamma Q(a, x) (Numerical Recipes: series / continued
/// fraction), the chi-square survival function is Q(k/2, x/2).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    fn ln_gamma(x: f64) -> f64 {
        let c = [
            76.180_091_729_471_46,
            -86.505_320_329_416_77,
            24.014_098_240_830_91,
            -1.231_739_572_450_155,
            0.120_865_097_386_617_9e-2,
            -0.539_523_938_495_3e-5,
        ];
        let mut y = x;
        let tmp = x + 5.5;
        let tmp = tmp - (x + 0.5) * tmp.ln();
        let mut ser = 1.000_000_000_190_015;
        for ci in c {
            y += 1.0;
            ser += ci / y;
        }
        -tmp + (2.506_628_274_631_000_5 * ser / x).ln()
    }
    if x <= 0.0 {
        return 1.0;
    }
    let gln = ln_gamma(a);
    if x < a + 1.0 {
        let mut ap = a;
        let mut sum = 1.0 / a;
        let mut del = sum;
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-14 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - gln).exp()
    } else {
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / 1e-300;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < 1e-300 {
                d = 1e-300;
            }
            c = b + an / c;
            if c.abs() < 1e-300 {
                c = 1e-300;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-14 {
                break;
            }
        }
        (-x + a * x.ln() - gln).exp() * h
    }
}

/// Result of a chi-square test.
#[derive(Debug)]
pub struct ChiSquare {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    pub sampled_fraction: f64,
    pub pdf_integral: f64,
}

pub const THETA_BINS: usize = 24;
pub const PHI_BINS: usize = 48;

/// Bins the sphere in `(cos θ, φ)`, draws `n` samples of `bsdf` for `wo`, integrates
/// `pdf` over every bin (`sub x sub` midpoints; the measure `d cos θ d φ` is solid angle),
/// pools the bins expecting fewer than 5 samples, and returns Pearson's statistic with its
/// p-value.
pub fn chi_square<B: Bsdf>(bsdf: &B, wo: Vec3, n: usize, seed: u64) -> ChiSquare {
    let mut rng = Pcg32::new(seed);
    let mut observed = vec![0f64; THETA_BINS * PHI_BINS];
    let mut got = 0usize;
    for _ in 0..n {
        let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        if let Some(s) = bsdf.sample(wo, u) {
            assert!(s.pdf > 0.0 && s.pdf.is_finite(), "bad pdf {}", s.pdf);
            assert!((s.wi.length() - 1.0).abs() < 1e-3, "wi not unit");
            let ct = (s.wi.z as f64).clamp(-1.0, 1.0);
            let mut phi = (s.wi.y as f64).atan2(s.wi.x as f64);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            let i = (((ct + 1.0) * 0.5 * THETA_BINS as f64) as usize).min(THETA_BINS - 1);
            let j = ((phi / (2.0 * PI) * PHI_BINS as f64) as usize).min(PHI_BINS - 1);
            observed[i * PHI_BINS + j] += 1.0;
            got += 1;
        }
    }
    let sub = 16;
    let mut expected = vec![0f64; THETA_BINS * PHI_BINS];
    let dct = 2.0 / THETA_BINS as f64;
    let dphi = 2.0 * PI / PHI_BINS as f64;
    let mut integral = 0.0;
    for i in 0..THETA_BINS {
        for j in 0..PHI_BINS {
            let mut s = 0.0;
            for a in 0..sub {
                for b in 0..sub {
                    let ct = -1.0 + (i as f64 + (a as f64 + 0.5) / sub as f64) * dct;
                    let phi = (j as f64 + (b as f64 + 0.5) / sub as f64) * dphi;
                    let st = (1.0 - ct * ct).max(0.0).sqrt();
                    let wi = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
                    s += bsdf.pdf(wo, wi) as f64;
                }
            }
            let e = s / (sub * sub) as f64 * dct * dphi;
            integral += e;
            expected[i * PHI_BINS + j] = e * n as f64;
        }
    }
    // Pool low-expectation bins.
    let mut idx: Vec<usize> = (0..expected.len()).collect();
    idx.sort_by(|&a, &b| expected[a].partial_cmp(&expected[b]).unwrap());
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    let mut stat = 0.0;
    let mut dof = 0usize;
    for &k in &idx {
        if expected[k] < 5.0 {
            pool_e += expected[k];
            pool_o += observed[k];
        } else {
            let d = observed[k] - expected[k];
            stat += d * d / expected[k];
            dof += 1;
        }
    }
    if pool_e > 0.0 {
        if pool_e >= 5.0 {
            let d = pool_o - pool_e;
            stat += d * d / pool_e;
            dof += 1;
        } else if pool_o > 0.0 && pool_o > 5.0 * pool_e.max(1.0) {
            // Samples where the pdf says there should be (almost) none.
            stat += pool_o * pool_o;
        }
    }
    let dof = dof.saturating_sub(1).max(1);
    let p_value = gamma_q(dof as f64 / 2.0, stat / 2.0);
    ChiSquare {
        statistic: stat,
        dof,
        p_value,
        sampled_fraction: got as f64 / n as f64,
        pdf_integral: integral,
    }
}

/// Šidák-corrected significance for `tests` simultaneous tests at level `alpha`.
pub fn sidak(alpha: f64, tests: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / tests as f64)
}

/// Directional albedo `∫ eval(wo, wi) dωi` split into reflection (wi on wo's side) and
/// transmission, by stratified importance sampling through `bsdf.sample`.
pub fn directional_albedo<B: Bsdf>(bsdf: &B, wo: Vec3, n: u32) -> (Vec3, Vec3) {
    // Jittered strata (unbiased: the lobe-selection thresholds fall inside strata).
    let (mut r, mut t) = (Vec3::ZERO, Vec3::ZERO);
    let lobes = 16u32;
    let total = (lobes * n * n) as f32;
    let mut rng = Pcg32::new(77);
    for l in 0..lobes {
        for i in 0..n {
            for j in 0..n {
                let u = Vec3::new(
                    (l as f32 + rng.next_f32()) / lobes as f32,
                    (i as f32 + rng.next_f32()) / n as f32,
                    (j as f32 + rng.next_f32()) / n as f32,
                );
                if let Some(s) = bsdf.sample(wo, u) {
                    let w = s.f / s.pdf / total;
                    if s.wi.z * wo.z > 0.0 {
                        r += w;
                    } else {
                        t += w;
                    }
                }
            }
        }
    }
    (r, t)
}

/// A direction from spherical angles in degrees.
pub fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Unit-square point from two numbers.
pub fn uv(x: f32, y: f32) -> Vec2 {
    Vec2::new(x, y)
}
