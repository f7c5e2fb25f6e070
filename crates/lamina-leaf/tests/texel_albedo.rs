//! `LeafBsdf::diffuse_albedo()` / `diffuse_albedo_abaxial()` are the white-sky albedos of the
//! lobes `eval` returns at the texel, also away from the nominal thickness and extinction.
//! The reference is a numerical integration of `eval` (specular off, no bump map).

use glam::{Vec2, Vec3, Vec4};
use lamina_leaf::*;
use std::f64::consts::PI;

/// A `n x n` map whose value ramps from 0 to 1 along `u` (or along `v` when `along_v`),
/// texel centres hitting `k / (n - 1)` exactly.
fn ramp(n: u32, along_v: bool) -> Texture {
    let texels = (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            // Row 0 is the top of the image (v = 1).
            let k = if along_v { n - 1 - y } else { x };
            Vec4::splat(k as f32 / (n - 1) as f32)
        })
        .collect();
    Texture::from_texels(n, n, texels, Wrap::Clamp)
}

const N: u32 = 11;

/// Texture coordinates of the texel with thickness `i / (N - 1)` and extinction `j / (N - 1)`.
fn texel(i: u32, j: u32) -> Vec2 {
    Vec2::new((i as f32 + 0.5) / N as f32, (j as f32 + 0.5) / N as f32)
}

fn material(mode: LeafMode, colours: bool) -> LeafMaterial {
    let c = |v: Vec3| Some(Texture::constant(v.extend(1.0)));
    let maps = LeafMaps {
        front: colours.then(|| c(Vec3::new(0.08, 0.2, 0.05))).flatten(),
        back: colours.then(|| c(Vec3::new(0.12, 0.25, 0.09))).flatten(),
        translucency: colours.then(|| c(Vec3::new(0.1, 0.3, 0.03))).flatten(),
        thickness: Some(ramp(N, false)),
        extinction: Some(ramp(N, true)),
        ..Default::default()
    };
    let params = LeafParams {
        mode,
        specular: 0.0,
        bump_scale: 0.0,
        thickness_variation: 0.8,
        extinction_strength: 0.8,
        ..Default::default()
    };
    LeafMaterial::new(maps, params).expect("valid material")
}

/// White-sky albedos (adaxial R, abaxial R, T) of `eval`: `(1/pi) ∫∫ f |cos_i| |cos_o|`,
/// i.e. the cosine-weighted mean over `wo` of the directional albedo. `mu = x^2` midpoints
/// (dense near grazing), `phi` midpoints over `[0, pi]` doubled (the lobes are symmetric).
fn white_sky(b: &LeafBsdf) -> [Vec3; 3] {
    const NM: usize = 64;
    const NP: usize = 24;
    let node = |i: usize| {
        let x = (i as f64 + 0.5) / NM as f64;
        (x * x, 2.0 * x / NM as f64)
    };
    let mut acc = [[0.0f64; 3]; 4];
    for io in 0..NM {
        let (mo, wmo) = node(io);
        let so = (1.0 - mo * mo).max(0.0).sqrt();
        for ii in 0..NM {
            let (mi, wmi) = node(ii);
            let si = (1.0 - mi * mi).max(0.0).sqrt();
            for k in 0..NP {
                let phi = PI * (k as f64 + 0.5) / NP as f64;
                // d(omega_i) = dmu dphi, phi doubled; wo weight cos_o / pi d(omega_o) with
                // its own phi integral giving 2 pi: (2 pi / pi) = 2.
                let w = (wmo * mo * 2.0) * (wmi * 2.0 * PI / NP as f64);
                let (sp, cp) = phi.sin_cos();
                let up_o = Vec3::new(so as f32, 0.0, mo as f32);
                let dn_o = Vec3::new(so as f32, 0.0, -mo as f32);
                let up_i = Vec3::new((si * cp) as f32, (si * sp) as f32, mi as f32);
                let dn_i = Vec3::new((si * cp) as f32, (si * sp) as f32, -mi as f32);
                for (lobe, (wo, wi)) in [(up_o, up_i), (dn_o, dn_i), (up_o, dn_i), (dn_o, up_i)]
                    .into_iter()
                    .enumerate()
                {
                    let f = b.eval(wo, wi);
                    for c in 0..3 {
                        acc[lobe][c] += f[c] as f64 * w;
                    }
                }
            }
        }
    }
    let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
    let t = [0, 1, 2].map(|c| 0.5 * (acc[2][c] + acc[3][c]));
    [v(acc[0]), v(acc[1]), v(t)]
}

fn check(m: &LeafMaterial, label: &str) -> f32 {
    let mut worst = 0.0f32;
    let mut failures = Vec::new();
    for (i, j) in [
        (0, 0),
        (0, 10),
        (5, 5),
        (10, 10),
        (10, 0),
        (1, 7),
        (3, 2),
        (0, 5),
        (5, 0),
        (9, 1),
    ] {
        let b = m.bsdf(texel(i, j));
        let (r, t) = b.diffuse_albedo();
        let claimed = [r, b.diffuse_albedo_abaxial(), t];
        let actual = white_sky(&b);
        for (lobe, name) in ["R adaxial", "R abaxial", "T"].iter().enumerate() {
            for c in 0..3 {
                let (x, y) = (claimed[lobe][c], actual[lobe][c]);
                let err = (x - y).abs();
                let rel = err / y.abs().max(1e-12);
                worst = worst.max(if err < 1e-3 { 0.0 } else { rel });
                if err > 1e-3 && rel > 0.02 {
                    failures.push(format!(
                        "{label} t={} e={} {name} ch{c}: diffuse_albedo {x:.5} eval {y:.5} \
                         ratio {:.3}",
                        i as f32 / (N - 1) as f32,
                        j as f32 / (N - 1) as f32,
                        x / y
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    worst
}

#[test]
fn diffuse_albedo_is_the_white_sky_albedo_of_eval_layered() {
    for colours in [true, false] {
        let w = check(&material(LeafMode::Layered, colours), "layered");
        println!("layered (colour maps: {colours}): worst relative error {w:.4}");
    }
}

#[test]
fn diffuse_albedo_is_the_white_sky_albedo_of_eval_eq1() {
    for colours in [true, false] {
        let w = check(&material(LeafMode::Eq1, colours), "eq1");
        println!("eq1 (colour maps: {colours}): worst relative error {w:.4}");
    }
}

#[test]
fn diffuse_albedo_is_the_white_sky_albedo_of_eval_diffuse() {
    for colours in [true, false] {
        let w = check(&material(LeafMode::Diffuse, colours), "diffuse");
        println!("diffuse (colour maps: {colours}): worst relative error {w:.4}");
    }
}

#[test]
fn nominal_texel_gives_the_map_colours() {
    for mode in [LeafMode::Layered, LeafMode::Eq1, LeafMode::Diffuse] {
        let m = material(mode, true);
        let b = m.bsdf(texel(5, 5));
        let (r, t) = b.diffuse_albedo();
        let [cf, cb, ct] = m.map_colours(texel(5, 5));
        // Exactly the map colours times the energy scale `lambda <= 1`, which is the same
        // for the three lobes (per channel).
        let lambda = r / cf;
        assert!(lambda.max_element() <= 1.0, "{mode:?} {lambda}");
        for (x, c) in [(b.diffuse_albedo_abaxial(), cb), (t, ct)] {
            for ch in 0..3 {
                let d = (x[ch] / c[ch] - lambda[ch]).abs();
                assert!(d <= 1e-5 * lambda[ch], "{mode:?} {x} {c} {lambda}");
            }
        }
    }
}

#[test]
fn constant_maps_keep_the_colours_everywhere() {
    // No thickness or extinction map: every texel is nominal, the albedos are the colours.
    let c = Vec3::new(0.08, 0.2, 0.05);
    let m = LeafMaterial::new(
        LeafMaps {
            front: Some(Texture::constant(c.extend(1.0))),
            ..Default::default()
        },
        LeafParams {
            specular: 0.0,
            ..Default::default()
        },
    )
    .unwrap();
    for uv in [Vec2::new(0.1, 0.9), Vec2::splat(0.5)] {
        let b = m.bsdf(uv);
        assert_eq!(b.diffuse_albedo().0, c);
        assert_eq!(b.diffuse_albedo(), m.bsdf(Vec2::ZERO).diffuse_albedo());
    }
}
