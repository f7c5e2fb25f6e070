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

/// Directional albedos of `eval` seen from `w`: `∫ eval(w, wi) dωi` over `w`'s hemisphere
/// (reflection) and over the other one (transmission). The subsurface lobes are
/// reciprocal, so these are also the albedos for light arriving from `w`. `mu = x^2`
/// midpoints (dense near grazing), azimuth midpoints over `[0, π]` doubled (`w` lies in
/// the x-z plane, the lobes are symmetric about it).
fn directional(b: &LeafBsdf, w: Vec3) -> (Vec3, Vec3) {
    const NM: usize = 64;
    const NP: usize = 24;
    let mut acc = [[0.0f64; 3]; 2];
    for i in 0..NM {
        let x = (i as f64 + 0.5) / NM as f64;
        let (mu, wmu) = (x * x, 2.0 * x / NM as f64);
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        for k in 0..NP {
            let phi = PI * (k as f64 + 0.5) / NP as f64;
            let weight = wmu * 2.0 * PI / NP as f64;
            for (lobe, z) in [(0, mu), (1, -mu)] {
                let z = if w.z > 0.0 { z } else { -z };
                let wi = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32);
                let f = b.eval(w, wi);
                for c in 0..3 {
                    acc[lobe][c] += f[c] as f64 * weight;
                }
            }
        }
    }
    let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
    (v(acc[0]), v(acc[1]))
}

/// The energy scale `lambda` of `LeafMaterial`'s documented bound, from `eval` alone: for
/// every incidence on either side, `C_R rho_R / A_R + C_T rho_T / A_T <= margin` with each
/// `rho / A` at its largest over the texels with the extreme thickness and extinction map
/// values (and the nominal one), `lambda` the largest value `<= 1` keeping that. `rho / A`
/// is `eval`'s directional albedo at the texel over its white-sky albedo at the nominal
/// texel (both carry the same factor `C lambda / A`, which cancels), `margin` 0.99 (1 in
/// diffuse mode without specular, where the table is exact); no specular lobe here.
fn expected_lambda(m: &LeafMaterial, mode: LeafMode, colours: [Vec3; 3]) -> Vec3 {
    let [cf, cb, ct] = colours;
    let nominal = white_sky(&m.bsdf(texel(5, 5)));
    let margin = if mode == LeafMode::Diffuse { 1.0 } else { 0.99 };
    let extremes =
        [(0, 0), (0, N - 1), (N - 1, 0), (N - 1, N - 1), (5, 5)].map(|(i, j)| m.bsdf(texel(i, j)));
    let mut demand = Vec3::ZERO;
    for (side, c_r) in [(0, cf), (1, cb)] {
        // The energy table's incidences: 48 midpoints in mu and normal incidence.
        for k in 0..=48 {
            let mu = if k == 48 {
                1.0
            } else {
                (k as f32 + 0.5) / 48.0
            };
            let s = (1.0 - mu * mu).max(0.0).sqrt();
            let w = Vec3::new(s, 0.0, if side == 0 { mu } else { -mu });
            let (mut r_max, mut t_max) = (Vec3::ZERO, Vec3::ZERO);
            for b in &extremes {
                let (r, t) = directional(b, w);
                r_max = r_max.max(r / nominal[side]);
                t_max = t_max.max(t / nominal[2]);
            }
            demand = demand.max(c_r * r_max + ct * t_max);
        }
    }
    (Vec3::splat(margin) / demand).min(Vec3::ONE)
}

#[test]
fn nominal_texel_gives_the_map_colours() {
    // Tolerance of the values: 1 %, for the quadrature error of `white_sky` and
    // `directional` against the material's own coarser tables; measured 0.39 % at worst.
    //
    // Only in eq1 mode is `lambda` 1 here. These maps span the whole thickness and
    // extinction range with variation and strength 0.8, and the bound takes `rho / A` at
    // the extreme texels for every texel, so the nominal texel's colours are scaled by
    // (measured, matching the bound computed here) lambda = (0.194, 0.498, 1.0e-4) in
    // layered mode and (0.0836, 0.422, 3.3e-8) in diffuse mode: this texel shows the map
    // colours times that, not the map colours.
    const TOL: f32 = 0.01;
    let mut worst = 0.0f32;
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
        // The values: the map colours are the photographed ones (`constant` holds linear
        // values), and `lambda` is what the documented energy bound gives, computed here
        // from `eval` by numerical integration; `eval`'s own white-sky albedos at the
        // nominal texel are those colours times that `lambda` as well.
        let colours = [
            Vec3::new(0.08, 0.2, 0.05),
            Vec3::new(0.12, 0.25, 0.09),
            Vec3::new(0.1, 0.3, 0.03),
        ];
        assert_eq!([cf, cb, ct], colours, "{mode:?}");
        let expected = expected_lambda(&m, mode, colours);
        let measured = white_sky(&b);
        let claimed = [r, b.diffuse_albedo_abaxial(), t];
        for lobe in 0..3 {
            for ch in 0..3 {
                let want = colours[lobe][ch] * expected[ch];
                for (what, got) in [
                    ("diffuse_albedo", claimed[lobe][ch]),
                    ("eval", measured[lobe][ch]),
                ] {
                    let rel = (got - want).abs() / want;
                    worst = worst.max(rel);
                    assert!(
                        rel <= TOL,
                        "{mode:?} lobe {lobe} ch {ch}: {what} {got} vs colour x lambda {want} \
                         (lambda {}, expected {})",
                        lambda[ch],
                        expected[ch]
                    );
                }
            }
        }
        println!("{mode:?}: lambda {lambda}, expected from eval {expected}");
    }
    println!("nominal texel: worst relative deviation from colour x lambda {worst:.2e}");
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
