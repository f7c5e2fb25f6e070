//! Tests of the bake against the CPU model.

use super::maps::encode;
use super::*;
use glam::Vec2;
use lamina_leaf::{LeafMaps, LeafMaterial, LeafParams};

#[test]
fn lambert_material_has_flat_tables() {
    let m = Material::Diffuse {
        name: "g".into(),
        reflectance: ColorInput::Constant(Vec3::new(0.5, 0.25, 0.1)),
        alpha: None,
    };
    let b = bake_material(&m, 16);
    assert_eq!((b.front.width, b.front.height), (1, 1));
    assert!((b.lut[5][1] - std::f32::consts::FRAC_1_PI).abs() < 1e-6);
    // 0.5 linear is 188 in sRGB.
    assert_eq!(b.front.levels[0][0], [188, 137, 89, 255]);
}

#[test]
fn leaf_tables_integrate_to_the_white_sky_albedo() {
    // g_X is normalised so that the white-sky albedo of f = albedo * g is albedo:
    // A / albedo = int_0^1 2 mu_i (int_0^1 2 pi mu_o g dmu_o) dmu_i = 1 per channel, up
    // to the table's midpoint quadrature (coarse near grazing: 8 % tolerance).
    let lut = leaf_lut(&LeafParams::default());
    for layer in 0..3 {
        let mut acc = Vec3::ZERO;
        for j in 0..LUT_N {
            for i in 0..LUT_N {
                let mo = (i as f32 + 0.5) / LUT_N as f32;
                let mi = (j as f32 + 0.5) / LUT_N as f32;
                let g = lut[(layer * LUT_N + j) * LUT_N + i];
                let w = (1.0 / LUT_N as f32).powi(2);
                acc +=
                    Vec3::new(g[0], g[1], g[2]) * (2.0 * mi * 2.0 * std::f32::consts::PI * mo * w);
            }
        }
        for c in 0..3 {
            assert!(
                (acc[c] - 1.0).abs() < 0.08,
                "layer {layer} channel {c}: {acc}"
            );
        }
    }
}

#[test]
fn oversized_maps_are_downscaled_with_a_warning() {
    let map = lamina_leaf::Texture::from_texels(
        64,
        32,
        vec![glam::Vec4::new(0.2, 0.4, 0.1, 1.0); 64 * 32],
        lamina_leaf::Wrap::Repeat,
    );
    let m = Material::Diffuse {
        name: "bark".into(),
        reflectance: ColorInput::Texture {
            map,
            factor: Vec3::ONE,
        },
        alpha: None,
    };
    let b = bake_material(&m, 16);
    assert_eq!((b.front.width, b.front.height), (16, 8));
    assert_eq!(b.warnings.len(), 1);
    assert!(b.warnings[0].contains("'bark'") && b.warnings[0].contains("limit of 16"));
    assert_eq!(b.front.levels.len(), 5); // 16x8, 8x4, 4x2, 2x1, 1x1
}

/// A glossy glTF material with a roughness/metallic map: the uniform carries
/// roughness², 1 − metallic and the metal colour from the maps' means, the Fresnel
/// table F0 = ((ior − 1)/(ior + 1))², and the front map the CPU model's diffuse albedo
/// at every texel centre.
#[test]
fn pbr_material_carries_the_cpu_model() {
    use lamina_scene::PbrMaterial;
    // 4x2 map: G (roughness) 0.5 and 1.0 in alternate columns, B (metallic) 0 and 0.5.
    let texels = (0..8)
        .map(|i| {
            if i % 2 == 0 {
                glam::Vec4::new(0.0, 0.5, 0.0, 1.0)
            } else {
                glam::Vec4::new(0.0, 1.0, 0.5, 1.0)
            }
        })
        .collect();
    let mr = lamina_leaf::Texture::from_texels(4, 2, texels, lamina_leaf::Wrap::Repeat);
    let base = Vec3::new(0.6, 0.3, 0.1);
    let mut p = PbrMaterial::uniform("pot", base, 0.8, 0.6);
    p.metallic_roughness = Some(mr);
    p.ior = 1.4;
    let m = Material::Pbr(Box::new(p.clone()));
    let b = bake_material(&m, 64);
    assert_eq!((b.front.width, b.front.height), (4, 2));
    // Mean roughness 0.6 * 0.75 = 0.45, mean metallic 0.8 * 0.25 = 0.2.
    let alpha = 0.45f32 * 0.45;
    assert!((b.uniform.spec[0] - alpha).abs() < 1e-4, "{:?}", b.uniform);
    assert!((b.uniform.spec[1] - alpha).abs() < 1e-4);
    assert!((b.uniform.spec[2] - 0.8).abs() < 1e-4);
    assert_eq!(b.uniform.spec[3], PBR_BLEND_SIN);
    let metal = base * 0.2;
    for c in 0..3 {
        assert!(
            (b.uniform.metal[c] - metal[c]).abs() < 1e-4,
            "{:?}",
            b.uniform
        );
    }
    assert!((b.uniform.metal[3] - 0.2).abs() < 1e-4);
    let f0 = ((1.4f32 - 1.0) / (1.4 + 1.0)).powi(2);
    let f = b.lut[3 * LUT_N * LUT_N + LUT_N - 1];
    // The last column is at cosine 1 - 1/64, where Fresnel is within 2e-5 of F0.
    assert!(
        (f[0] - f0).abs() < 5e-5 && (f[1] - f0).abs() < 5e-5,
        "{f:?} vs {f0}"
    );
    let exact = lamina_leaf::layers::fresnel_dielectric(1.0 - 0.5 / LUT_N as f32, 1.4);
    assert_eq!((f[0], f[1]), (exact, exact));
    // Front albedo at texel centres: the CPU model's, to 8-bit sRGB quantisation.
    for y in 0..2 {
        for x in 0..4 {
            let uv = Vec2::new((x as f32 + 0.5) / 4.0, 1.0 - (y as f32 + 0.5) / 2.0);
            let (r, _) = p.bsdf(uv).diffuse_albedo();
            let want = encode([r.x, r.y, r.z, 1.0]);
            let got = b.front.levels[0][y * 4 + x];
            assert_eq!(got, want, "texel {x},{y}");
            assert_eq!(b.back.levels[0][y * 4 + x], want);
        }
    }
    // The metallic texels reflect less diffusely than the dielectric ones.
    assert!(b.front.levels[0][1][0] < b.front.levels[0][0][0]);
    // No normal map: the flat one, flagged off.
    assert_eq!(b.uniform.shape[1], 0.0);
    assert_eq!(b.normal.levels[0], vec![[128, 128, 255, 255]]);
}

/// A normal map is baked linearly (with its scale) at its own size and flagged on.
#[test]
fn pbr_normal_map_is_baked_linearly() {
    use lamina_scene::{NormalMap, PbrMaterial};
    let c = Vec3::new(0.7, 0.4, 0.9);
    let map = lamina_leaf::Texture::from_texels(
        8,
        4,
        vec![glam::Vec4::new(c.x, c.y, c.z, 1.0); 32],
        lamina_leaf::Wrap::Repeat,
    );
    let mut p = PbrMaterial::uniform("tile", Vec3::splat(0.5), 0.0, 0.5);
    p.normal_map = Some(NormalMap { map, scale: 0.5 });
    let want = p.normal_map.as_ref().unwrap().at(Vec2::splat(0.5));
    let b = bake_material(&Material::Pbr(Box::new(p)), 64);
    assert_eq!(b.uniform.shape[1], 1.0);
    assert_eq!((b.normal.width, b.normal.height), (8, 4));
    let got = b.normal.levels[0][5];
    for k in 0..3 {
        let decoded = got[k] as f32 / 255.0 * 2.0 - 1.0;
        assert!((decoded - want[k]).abs() < 0.01, "{got:?} vs {want}");
    }
}

/// A leaf's bump map is baked to the shading normal LeafMaterial uses at every texel
/// centre (to 8-bit quantisation), in the CPU leaf frame: a height rising along `u`
/// and `v` tilts the normal towards `-x` and `-y` (`y` towards increasing `v`). A leaf
/// without a bump map keeps the flat 1x1 map, flagged off.
#[test]
fn leaf_bump_map_bakes_to_the_cpu_shading_normal() {
    use lamina_leaf::{Texture, Wrap};
    let (w, h) = (8u32, 4u32);
    // A linear ramp h = 0.25 u + 0.5 v sampled at texel centres (top row first).
    let texels = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let (u, v) = ((x + 0.5) / w as f32, 1.0 - (y + 0.5) / h as f32);
            glam::Vec4::splat(0.25 * u + 0.5 * v)
        })
        .collect();
    let maps = LeafMaps {
        bump: Some(Texture::from_texels(w, h, texels, Wrap::Clamp)),
        ..Default::default()
    };
    let params = LeafParams {
        bump_scale: 1.0,
        ..LeafParams::default()
    };
    let leaf = std::sync::Arc::new(LeafMaterial::new(maps, params).unwrap());
    let m = Material::Leaf {
        name: "bumpy".into(),
        leaf: leaf.clone(),
    };
    let b = bake_material(&m, 64);
    assert_eq!((b.normal.width, b.normal.height), (w, h));
    assert_eq!((b.uniform.shape[1], b.uniform.shape[2]), (1.0, 1.0));
    let decode = |t: [u8; 4]| Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32) / 127.5 - Vec3::ONE;
    let exact = Vec3::new(-0.25, -0.5, 1.0).normalize();
    for y in 0..h {
        for x in 0..w {
            let uv = Vec2::new(
                (x as f32 + 0.5) / w as f32,
                1.0 - (y as f32 + 0.5) / h as f32,
            );
            let cpu = leaf.bsdf(uv).shading_normal();
            let got = decode(b.normal.levels[0][(y * w + x) as usize]);
            assert!(
                (got - cpu).abs().max_element() <= 1.0 / 255.0 + 1e-6,
                "texel {x},{y}: {got} vs {cpu}"
            );
            // Away from the clamped border the central differences see the ramp.
            if (1..w - 1).contains(&x) && (1..h - 1).contains(&y) {
                assert!(
                    (cpu - exact).length() < 1e-4,
                    "texel {x},{y}: {cpu} vs {exact}"
                );
            }
        }
    }
    // Without a bump map (or with bump_scale 0): flat and flagged off.
    for (maps, scale) in [(LeafMaps::default(), 1.0), (leaf.maps().clone(), 0.0)] {
        let params = LeafParams {
            bump_scale: scale,
            ..LeafParams::default()
        };
        let flat = Material::Leaf {
            name: "flat".into(),
            leaf: std::sync::Arc::new(LeafMaterial::new(maps, params).unwrap()),
        };
        let b = bake_material(&flat, 64);
        assert_eq!(b.uniform.shape[1], 0.0);
        assert_eq!(b.uniform.shape[2], 1.0);
        assert_eq!(b.normal.levels[0], vec![[128, 128, 255, 255]]);
    }
}

/// The glTF tables: white-sky normalised diffuse shapes, darker than Lambertian at
/// grazing angles (the coupling with the specular coat), and the albedo rows.
#[test]
fn pbr_tables_are_normalised() {
    let lut = pbr_lut(0.4, 1.5);
    for layer in 0..3 {
        let mut acc = 0.0;
        for j in 0..LUT_N {
            for i in 0..LUT_N {
                let mo = (i as f32 + 0.5) / LUT_N as f32;
                let mi = (j as f32 + 0.5) / LUT_N as f32;
                let g = lut[(layer * LUT_N + j) * LUT_N + i][0];
                acc += g * 4.0 * std::f32::consts::PI * mo * mi / (LUT_N * LUT_N) as f32;
            }
        }
        assert!((acc - 1.0).abs() < 0.03, "layer {layer}: {acc}");
        let grazing = lut[(layer * LUT_N) * LUT_N][0];
        let normal = lut[(layer * LUT_N + LUT_N - 1) * LUT_N + LUT_N - 1][0];
        assert!(grazing < normal, "layer {layer}: {grazing} vs {normal}");
    }
    let row0 = &lut[3 * LUT_N * LUT_N..3 * LUT_N * LUT_N + LUT_N];
    let row1 = &lut[(3 * LUT_N + 1) * LUT_N..(3 * LUT_N + 2) * LUT_N];
    for i in 0..LUT_N {
        // E(mu) of the dielectric lies between F0 and 1; E1 near 1 for moderate
        // roughness at normal incidence; E5 small.
        assert!(row0[i][2] > 0.03 && row0[i][2] < 1.0, "{:?}", row0[i]);
        assert!(row1[i][0] > row1[i][1] && row1[i][1] >= 0.0);
    }
    assert!(row1[LUT_N - 1][0] > 0.9, "{:?}", row1[LUT_N - 1]);
    // An index-matched surface is Lambertian with no specular.
    let flat = pbr_lut(0.4, 1.0);
    assert!((flat[7][0] - std::f32::consts::FRAC_1_PI).abs() < 1e-4);
    assert_eq!(flat[3 * LUT_N * LUT_N + 5][2], 0.0);
}
