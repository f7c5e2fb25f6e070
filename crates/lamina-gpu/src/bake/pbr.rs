//! glTF metallic-roughness materials ([`Material::Pbr`], [`lamina_leaf::PbrBsdf`]): the
//! diffuse albedo maps, the mean roughness and metallic of the single GGX lobe, the
//! angular tables from the CPU model's public API, and the normal map (see the [`super`]
//! docs).

use super::maps::{
    bake_texels, colour_size, encode_linear, fill_transparent, fit, flat_normal, mip_chain,
    mip_chain_with,
};
use super::{BakedMaterial, LUT_LAYERS, LUT_N, MaterialUniform};
use glam::{Vec2, Vec3};
use lamina_leaf::Bsdf;
#[cfg(doc)]
use lamina_scene::Material;

/// Sine of the front/back blend width baked for [`Material::Pbr`]. The shader fades the
/// specular lobe by `smooth(mu_o / w) smooth(mu_i / w)`, which leaves need (their
/// specular is faded over `LeafParams::blend_width_deg` on the CPU too); the glTF surface
/// has no such band, its lobe already vanishes at the plane through the Smith `G2`. A
/// width of 0.06 degrees keeps the shader's division finite while changing nothing outside
/// the last 1e-3 of cosine, where `G2` has already removed the lobe.
pub const PBR_BLEND_SIN: f32 = 1e-3;

/// Side of the grid on which a glTF material's maps are averaged for its scalar shading
/// constants (roughness, metallic, metal colour).
const PBR_STATS_N: u32 = 128;

/// Mean perceptual roughness, mean metallic and mean `metallic · base_colour` of a glTF
/// material over its opaque texels (all texels when none is opaque), sampled at the
/// centres of an up to `PBR_STATS_N²` grid.
fn pbr_means(p: &lamina_scene::PbrMaterial, w: u32, h: u32) -> (f32, f32, Vec3) {
    let (nw, nh) = (w.clamp(1, PBR_STATS_N), h.clamp(1, PBR_STATS_N));
    let mut acc = [(0.0f64, 0.0f64, glam::DVec3::ZERO, 0u32); 2];
    for y in 0..nh {
        for x in 0..nw {
            let uv = Vec2::new(
                (x as f32 + 0.5) / nw as f32,
                1.0 - (y as f32 + 0.5) / nh as f32,
            );
            let b = p.bsdf(uv);
            let opaque = p.alpha.as_ref().is_none_or(|m| m.opaque(uv));
            for a in &mut acc[..if opaque { 2 } else { 1 }] {
                a.0 += b.roughness as f64;
                a.1 += b.metallic as f64;
                a.2 += (b.base_color * b.metallic).as_dvec3();
                a.3 += 1;
            }
        }
    }
    let a = if acc[1].3 > 0 { acc[1] } else { acc[0] };
    let n = a.3.max(1) as f64;
    ((a.0 / n) as f32, (a.1 / n) as f32, (a.2 / n).as_vec3())
}

/// The angular tables of a glTF material ([`lamina_leaf::PbrBsdf`]) of perceptual
/// roughness `roughness` and index `ior`, from its public API only:
///
/// * layers 0 and 1 (reflection, the surface is two-sided): the diffuse reflection lobe
///   alone, `eval` of a white base minus `eval` of a black one (the dielectric specular
///   lobe does not depend on the base colour), divided by `mu_i` and by the white-sky
///   albedo `diffuse_albedo().0`. With the energy-conserving coupling this is
///   `(1 − E(mu_o))(1 − E(mu_i)) / (pi (1 − E_avg)²)`: darker than Lambertian at grazing
///   angles, where the specular coat takes the light;
/// * layer 2: the diffuse transmission lobe of a fully transmitting white material the same
///   way (it sees no specular lobe at all);
/// * layer 3, row 0: the dielectric Fresnel `fresnel_dielectric(c, max(ior, 1/ior))` (`r`,
///   `g`: both sides) and the dielectric specular lobe's directional albedo `E(c)` (`b`,
///   `a`: `directional_albedo` of a black dielectric); row 1: the metal lobe's albedo
///   moments, `r` = `E1(c)` for `F ≡ 1` (a white metal's albedo) and `g` = `E5(c)` for
///   `F = (1 − v·h)⁵` (a black metal's), so that a metal of colour `F0` reflects
///   `F0 E1 + (1 − F0) E5` of the sky (Schlick's albedo, exact per channel).
pub fn pbr_lut(roughness: f32, ior: f32) -> Vec<[f32; 4]> {
    use lamina_leaf::PbrBsdf;
    let mut lut = vec![[0.0f32; 4]; LUT_N * LUT_N * LUT_LAYERS];
    let white = PbrBsdf {
        base_color: Vec3::ONE,
        metallic: 0.0,
        roughness,
        ior,
        transmission: 0.0,
        transmission_color: Vec3::ONE,
    };
    let black = PbrBsdf {
        base_color: Vec3::ZERO,
        ..white
    };
    let through = PbrBsdf {
        transmission: 1.0,
        ..white
    };
    let a_r = white.diffuse_albedo().0.x;
    let a_t = through.diffuse_albedo().1.x;
    let mu = |k: usize| (k as f32 + 0.5) / LUT_N as f32;
    let dir = |m: f32| Vec3::new((1.0 - m * m).max(0.0).sqrt(), 0.0, m);
    for j in 0..LUT_N {
        let mi = mu(j);
        let wi = dir(mi);
        let wi_dn = Vec3::new(wi.x, wi.y, -wi.z);
        for i in 0..LUT_N {
            let wo = dir(mu(i));
            // Opposite azimuths: the diffuse lobes do not depend on it, and the specular
            // lobe (cancelled anyway) is then far from its peak.
            let wo = Vec3::new(-wo.x, wo.y, wo.z);
            let r = (white.eval(wo, wi).x - black.eval(wo, wi).x) / mi;
            let t = through.eval(wo, wi_dn).x / mi;
            let gr = if a_r > 1e-6 {
                r / a_r
            } else {
                std::f32::consts::FRAC_1_PI
            };
            let gt = if a_t > 1e-6 {
                t / a_t
            } else {
                std::f32::consts::FRAC_1_PI
            };
            for (l, g) in [gr, gr, gt].into_iter().enumerate() {
                lut[(l * LUT_N + j) * LUT_N + i] = [g, g, g, 1.0];
            }
        }
    }
    let eta = if ior >= 1.0 { ior } else { 1.0 / ior.max(1e-3) };
    let metal_white = PbrBsdf {
        metallic: 1.0,
        ..white
    };
    let metal_black = PbrBsdf {
        metallic: 1.0,
        ..black
    };
    for i in 0..LUT_N {
        let c = mu(i);
        let wo = dir(c);
        let f = lamina_leaf::layers::fresnel_dielectric(c, eta);
        let e = black.directional_albedo(wo).0.x;
        lut[3 * LUT_N * LUT_N + i] = [f, f, e, e];
        lut[(3 * LUT_N + 1) * LUT_N + i] = [
            metal_white.directional_albedo(wo).0.x,
            metal_black.directional_albedo(wo).0.x,
            0.0,
            0.0,
        ];
    }
    lut
}

/// Bakes a glTF metallic-roughness material (see the module docs).
pub(super) fn bake_pbr(
    p: &lamina_scene::PbrMaterial,
    max_dim: u32,
    mut warnings: Vec<String>,
) -> BakedMaterial {
    let (mut w, mut h) = colour_size(&p.base_color);
    for (tw, th) in [
        p.metallic_roughness
            .as_ref()
            .map(|t| (t.width(), t.height())),
        p.transmission_map.as_ref().map(|t| (t.width(), t.height())),
        Some(colour_size(&p.transmission_color)),
        p.alpha.as_ref().map(|a| (a.map.width(), a.map.height())),
    ]
    .into_iter()
    .flatten()
    {
        (w, h) = (w.max(tw), h.max(th));
    }
    let (w, h) = fit(&p.name, "the material's maps", w, h, max_dim, &mut warnings);
    let mut maps = bake_texels(w, h, &|uv| {
        let (r, t) = p.bsdf(uv).diffuse_albedo();
        let a = p.alpha.as_ref().is_none_or(|m| m.opaque(uv));
        [
            [r.x, r.y, r.z, if a { 1.0 } else { 0.0 }],
            [r.x, r.y, r.z, 1.0],
            [t.x, t.y, t.z, 1.0],
        ]
    });
    fill_transparent(&mut maps);
    let [f, b, t] = maps;
    let (roughness, metallic, metal) = pbr_means(p, w, h);
    let normal = match &p.normal_map {
        Some(nm) => {
            let (nw, nh) = fit(
                &p.name,
                "the normal map",
                nm.map.width(),
                nm.map.height(),
                max_dim,
                &mut warnings,
            );
            let [n, _, _] = bake_texels(nw, nh, &|uv| {
                let v = nm.at(uv) * 0.5 + Vec3::splat(0.5);
                [[v.x, v.y, v.z, 1.0], [0.0; 4], [0.0; 4]]
            });
            Some(mip_chain_with(nw, nh, n, encode_linear))
        }
        None => None,
    };
    let mapped = normal.is_some();
    let alpha = (roughness * roughness).max(lamina_leaf::pbr::ALPHA_MIN);
    BakedMaterial {
        name: p.name.clone(),
        front: mip_chain(w, h, f),
        back: mip_chain(w, h, b),
        trans: mip_chain(w, h, t),
        normal: normal.unwrap_or_else(flat_normal),
        lut: pbr_lut(roughness, p.ior),
        uniform: MaterialUniform {
            spec: [alpha, alpha, 1.0 - metallic, PBR_BLEND_SIN],
            shape: [0.0, if mapped { 1.0 } else { 0.0 }, 0.0, 0.0],
            metal: [metal.x, metal.y, metal.z, metallic],
        },
        warnings,
    }
}
