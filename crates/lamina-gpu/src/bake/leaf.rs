//! Leaf materials ([`LeafMaterial`]): the albedo maps and bump normals per texel, the
//! angular tables of the pure physical model and the specular lobe's albedo, and the
//! shading constants from [`LeafParams`] (see the [`super`] docs).

use super::maps::{
    bake_texels, encode_linear, fill_transparent, fit, flat_normal, mip_chain, mip_chain_with,
};
use super::{BakedMaterial, LUT_LAYERS, LUT_N, MaterialUniform, MipMap, lambert_lut};
use glam::{Vec2, Vec3};
use lamina_leaf::{Bsdf, LeafMaps, LeafMaterial, LeafParams};

/// Bakes a leaf material named `name` (see the module docs) under the texture side limit
/// `max_dim`.
pub(super) fn bake_leaf(
    name: &str,
    leaf: &LeafMaterial,
    max_dim: u32,
    mut warnings: Vec<String>,
) -> BakedMaterial {
    let maps = leaf.maps();
    let (mut w, mut h) = (1, 1);
    for t in [
        &maps.front,
        &maps.back,
        &maps.translucency,
        &maps.alpha,
        &maps.thickness,
        &maps.extinction,
        &maps.bump,
    ]
    .into_iter()
    .flatten()
    {
        w = w.max(t.width());
        h = h.max(t.height());
    }
    let (w, h) = fit(name, "the leaf maps", w, h, max_dim, &mut warnings);
    let mut maps = bake_texels(w, h, &|uv| {
        let bsdf = leaf.bsdf(uv);
        let (r, t) = bsdf.diffuse_albedo();
        let rb = bsdf.diffuse_albedo_abaxial();
        let a = if leaf.opaque(uv) { 1.0 } else { 0.0 };
        [
            [r.x, r.y, r.z, a],
            [rb.x, rb.y, rb.z, 1.0],
            [t.x, t.y, t.z, 1.0],
        ]
    });
    fill_transparent(&mut maps);
    let [f, b, t] = maps;
    let params = *leaf.params();
    let normal = leaf_bump_normals(leaf, w, h);
    let mut uniform = leaf_uniform(&params);
    if normal.is_some() {
        uniform.shape[1] = 1.0;
    }
    BakedMaterial {
        name: name.to_string(),
        front: mip_chain(w, h, f),
        back: mip_chain(w, h, b),
        trans: mip_chain(w, h, t),
        normal: normal.unwrap_or_else(flat_normal),
        lut: leaf_lut(&params),
        uniform,
        warnings,
    }
}

/// The angular tables of a leaf's physical model (see the module docs).
pub fn leaf_lut(params: &LeafParams) -> Vec<[f32; 4]> {
    let mut lut = vec![[0.0f32; 4]; LUT_N * LUT_N * LUT_LAYERS];
    // The pure model: no maps, specular off, so eval = subsurface lobes only.
    let p = LeafParams {
        specular: 0.0,
        bump_scale: 0.0,
        ..*params
    };
    let Ok(m) = LeafMaterial::new(LeafMaps::default(), p) else {
        return lambert_lut();
    };
    let b = m.bsdf(Vec2::splat(0.5));
    let (r_ad, t) = b.diffuse_albedo();
    let r_ab = b.diffuse_albedo_abaxial();
    const NPHI: usize = 16;
    let mu = |k: usize| (k as f32 + 0.5) / LUT_N as f32;
    for j in 0..LUT_N {
        let mi = mu(j);
        let si = (1.0 - mi * mi).max(0.0).sqrt();
        for i in 0..LUT_N {
            let mo = mu(i);
            let so = (1.0 - mo * mo).max(0.0).sqrt();
            let mut acc = [Vec3::ZERO; 3];
            for k in 0..NPHI {
                // Azimuth difference over [0, pi] (the lobes are symmetric in it).
                let phi = std::f32::consts::PI * (k as f32 + 0.5) / NPHI as f32;
                let wo = Vec3::new(so * phi.cos(), so * phi.sin(), mo);
                let wi_up = Vec3::new(si, 0.0, mi);
                let wi_dn = Vec3::new(si, 0.0, -mi);
                let flip = Vec3::new(1.0, 1.0, -1.0);
                acc[0] += b.eval(wo, wi_up) / mi;
                acc[1] += b.eval(wo * flip, wi_dn) / mi;
                // Transmission, averaged over both directions through the blade.
                acc[2] += 0.5 * (b.eval(wo * flip, wi_up) + b.eval(wo, wi_dn)) / mi;
            }
            for (l, (a, alb)) in acc.iter().zip([r_ad, r_ab, t]).enumerate() {
                let g = *a / NPHI as f32;
                let g = Vec3::from_array([0, 1, 2].map(|c| {
                    if alb[c] > 1e-6 {
                        g[c] / alb[c]
                    } else {
                        std::f32::consts::FRAC_1_PI
                    }
                }));
                lut[(l * LUT_N + j) * LUT_N + i] = [g.x, g.y, g.z, 1.0];
            }
        }
    }
    let eta = [params.upper.ior, params.lower.ior];
    let alpha = [params.roughness_adaxial, params.roughness_abaxial];
    for i in 0..LUT_N {
        let c = mu(i);
        let [sa, sb] = [0, 1].map(|side| specular_albedo(c, alpha[side], eta[side], params));
        lut[3 * LUT_N * LUT_N + i] = [
            lamina_leaf::layers::fresnel_dielectric(c, eta[0]),
            lamina_leaf::layers::fresnel_dielectric(c, eta[1]),
            sa,
            sb,
        ];
    }
    lut
}

/// Directional albedo of the leaf's specular lobe (weight 1) for viewing cosine `mu_o`:
/// `int f_spec cos dw_i` of [`lamina_leaf::specular::eval`] with the blend-band fade of
/// `LeafBsdf`, by midpoint quadrature (the GPU scales sky light reflected by the surface
/// with it).
fn specular_albedo(mu_o: f32, alpha: f32, eta: f32, params: &LeafParams) -> f32 {
    const NM: usize = 48;
    const NP: usize = 48;
    let blend = params.blend_width_deg.to_radians().sin();
    let smooth = |x: f32| {
        let x = x.clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    };
    let wo = Vec3::new((1.0 - mu_o * mu_o).max(0.0).sqrt(), 0.0, mu_o);
    let mut acc = 0.0;
    for a in 0..NM {
        let mi = (a as f32 + 0.5) / NM as f32;
        let si = (1.0 - mi * mi).max(0.0).sqrt();
        for b in 0..NP {
            let phi = std::f32::consts::TAU * (b as f32 + 0.5) / NP as f32;
            let wi = Vec3::new(si * phi.cos(), si * phi.sin(), mi);
            let fade = smooth(mu_o / blend) * smooth(mi / blend);
            acc += lamina_leaf::specular::eval(wo, wi, alpha, eta) * fade;
        }
    }
    acc * std::f32::consts::TAU / (NM * NP) as f32
}

/// The shading constants of a leaf, from its parameters: `shape.z = 1` marks the normal
/// map as a leaf bump map (sides and the angular tables stay geometric, the bump enters
/// the shading cosines and the specular lobe only); `shape.y` is set by
/// [`super::bake_material`] when the leaf has a bump map.
pub fn leaf_uniform(params: &LeafParams) -> MaterialUniform {
    MaterialUniform {
        spec: [
            params.roughness_adaxial,
            params.roughness_abaxial,
            params.specular,
            params.blend_width_deg.to_radians().sin(),
        ],
        shape: [0.0, 0.0, 1.0, 0.0],
        metal: [0.0; 4],
    }
}

/// A leaf's bump map as a tangent-space normal map (see the module docs): at every texel
/// centre of the `w x h` grid of the leaf's baked maps, the shading normal
/// [`LeafMaterial::bsdf`] builds from the bump map's gradient, in the CPU leaf frame
/// (`x` = `dP/du`, `y` = `z × x`, `z` = the adaxial normal), stored linearly as
/// `n · 0.5 + 0.5`. `None` without a bump map or with `bump_scale` 0 (the flat normal).
fn leaf_bump_normals(leaf: &LeafMaterial, w: u32, h: u32) -> Option<MipMap> {
    leaf.maps().bump.as_ref()?;
    if leaf.params().bump_scale <= 0.0 {
        return None;
    }
    let [n, _, _] = bake_texels(w, h, &|uv| {
        let v = leaf.bsdf(uv).shading_normal() * 0.5 + Vec3::splat(0.5);
        [[v.x, v.y, v.z, 1.0], [0.0; 4], [0.0; 4]]
    });
    Some(mip_chain_with(w, h, n, encode_linear))
}
