//! CPU-side baking: every scene material becomes the same three GPU maps plus an angular
//! lookup table, computed **by evaluating lamina-leaf's model**, so the real-time shading is
//! tied to the offline BSDF by construction rather than by copied constants.
//!
//! # What is baked, per material
//! * **Albedo maps** (`front`, `back`, `trans`; 8-bit sRGB-encoded linear Rec.709, filtered
//!   in linear space by the GPU): at every texel centre, [`LeafMaterial::bsdf`] is evaluated
//!   and its white-sky diffuse albedos are stored: adaxial reflectance (`front`, alpha channel
//!   = the alpha matte, 0 or 1), abaxial reflectance (`back`) and diffuse transmittance
//!   (`trans`). These already contain everything the CPU model derives per texel from the
//!   seven maps: the photo colours, the energy bound `lambda`, and the Kubelka-Munk
//!   variation with the **thickness and extinction maps** (thicker or more absorbing texels,
//!   e.g. veins, transmit less). The GPU's through-light therefore follows the thickness
//!   and extinction maps exactly at normal white-sky illumination.
//! * **Angular tables** (`lut`, 32 x 32 per lobe, linear RGB, 1/sr): the physical lobe's
//!   shape `g_X(mu_o, mu_i) = <f_X(wo, wi)>_phi / a_X`, i.e. the CPU BSDF (specular off,
//!   nominal texel, no maps) averaged over the azimuth difference and divided by the lobe's
//!   white-sky albedo `a_X`, for `X` = adaxial reflection, abaxial reflection,
//!   transmission. A Lambertian lobe gives `1/pi` everywhere. The GPU evaluates
//!   `f cos = albedo_X(texel) * g_X(mu_o, mu_i) * mu_i`. Layer 3 holds the Fresnel
//!   reflectance of the adaxial (`r`) and abaxial (`g`) epidermis against the cosine
//!   (row 0), from [`lamina_leaf::layers::fresnel_dielectric`], and the specular lobe's
//!   directional albedo per side (`b`, `a`) from [`lamina_leaf::specular::eval`].
//! * **Uniforms**: GGX roughness per side, specular weight, the sine of the blend width,
//!   all read from [`LeafParams`].
//!
//! Mip levels are box-filtered here in linear space. Maps larger than the device's texture
//! limit are **downscaled with a warning** (returned in [`BakedMaterial::warnings`]).

use glam::{Vec2, Vec3};
use lamina_leaf::texture::linear_to_srgb;
use lamina_leaf::{Bsdf, LeafMaps, LeafMaterial, LeafParams};
use lamina_scene::{AlphaMask, ColorInput, Material};

/// Side of the angular tables (cosine samples at midpoints `(k + 0.5) / LUT_N`).
pub const LUT_N: usize = 32;
/// Layers of the angular table: adaxial R, abaxial R, T, Fresnel.
pub const LUT_LAYERS: usize = 4;

/// Per-material shading constants as the WGSL `MaterialParams` struct sees them.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MaterialUniform {
    /// `x`: GGX alpha of the adaxial (upper, +normal) side; `y`: of the abaxial side;
    /// `z`: specular weight in `[0, 1]` (0 for non-leaf materials); `w`: `sin` of the
    /// front/back blend width (`LeafParams::blend_width_deg`).
    pub spec: [f32; 4],
    /// `x`: radius (m) of a disc with the area of one card (two triangles) of this
    /// material, set by the renderer from the meshes: light a leaf transmits leaves it
    /// diffusely, so a receiver `d` behind it gets the fraction `a² / (a² + d²)` of it (the
    /// on-axis form factor of a disc of radius `a`). `yzw` unused.
    pub shape: [f32; 4],
}

/// One 2D RGBA8 map with its mip chain (level 0 first), sRGB-encoded colour, linear alpha.
#[derive(Clone, Debug)]
pub struct MipMap {
    /// Width of level 0.
    pub width: u32,
    /// Height of level 0.
    pub height: u32,
    /// Texels per level, row-major, top row (`v = 1`) first.
    pub levels: Vec<Vec<[u8; 4]>>,
}

/// A material ready for upload.
#[derive(Clone, Debug)]
pub struct BakedMaterial {
    /// The scene material's name.
    pub name: String,
    /// Adaxial diffuse reflectance, alpha = matte.
    pub front: MipMap,
    /// Abaxial diffuse reflectance.
    pub back: MipMap,
    /// Diffuse transmittance.
    pub trans: MipMap,
    /// Angular tables, `LUT_LAYERS` layers of `LUT_N x LUT_N` RGBA (index `x` = `mu_o`,
    /// `y` = `mu_i`), 1/sr.
    pub lut: Vec<[f32; 4]>,
    /// Shading constants.
    pub uniform: MaterialUniform,
    /// Messages for the user (downscaled maps).
    pub warnings: Vec<String>,
}

/// Linear RGB + alpha at one texel, before encoding.
type Texel = [f32; 4];

fn encode(c: Texel) -> [u8; 4] {
    let q = |x: f32| (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    [
        q(linear_to_srgb(c[0])),
        q(linear_to_srgb(c[1])),
        q(linear_to_srgb(c[2])),
        q(c[3]),
    ]
}

/// Builds the mip chain of a linear map by 2x2 box filtering (odd sides clamp).
fn mip_chain(width: u32, height: u32, base: Vec<Texel>) -> MipMap {
    let mut levels = vec![base.iter().map(|&t| encode(t)).collect::<Vec<_>>()];
    let (mut w, mut h, mut cur) = (width, height, base);
    while w > 1 || h > 1 {
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut next = vec![[0.0; 4]; (nw * nh) as usize];
        for y in 0..nh {
            for x in 0..nw {
                let mut acc = [0.0f32; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let sx = (2 * x + dx).min(w - 1);
                    let sy = (2 * y + dy).min(h - 1);
                    let t = cur[(sy * w + sx) as usize];
                    for c in 0..4 {
                        acc[c] += 0.25 * t[c];
                    }
                }
                next[(y * nw + x) as usize] = acc;
            }
        }
        levels.push(next.iter().map(|&t| encode(t)).collect());
        (w, h, cur) = (nw, nh, next);
    }
    MipMap {
        width,
        height,
        levels,
    }
}

/// The bake resolution for maps of size `(w, h)` under the texture limit, with a warning
/// naming the material and the limit when it had to shrink.
fn fit(
    name: &str,
    what: &str,
    w: u32,
    h: u32,
    limit: u32,
    warnings: &mut Vec<String>,
) -> (u32, u32) {
    let m = w.max(h);
    if m <= limit {
        return (w.max(1), h.max(1));
    }
    let s = limit as f32 / m as f32;
    let (nw, nh) = (
        ((w as f32 * s) as u32).clamp(1, limit),
        ((h as f32 * s) as u32).clamp(1, limit),
    );
    warnings.push(format!(
        "material '{name}': {what} is {w}x{h}, over the GPU's texture limit of {limit}; \
         downscaled to {nw}x{nh} for the GPU path"
    ));
    (nw, nh)
}

/// Evaluates `f(uv)` at every texel centre of a `w x h` map (top row first), on all cores.
fn bake_texels(w: u32, h: u32, f: &(dyn Fn(Vec2) -> [Texel; 3] + Sync)) -> [Vec<Texel>; 3] {
    let n = (w * h) as usize;
    let mut out = [vec![[0.0; 4]; n], vec![[0.0; 4]; n], vec![[0.0; 4]; n]];
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(16);
    let rows_per = (h as usize).div_ceil(threads).max(1);
    let [a, b, c] = &mut out;
    std::thread::scope(|s| {
        for (((ca, cb), cc), chunk) in a
            .chunks_mut(rows_per * w as usize)
            .zip(b.chunks_mut(rows_per * w as usize))
            .zip(c.chunks_mut(rows_per * w as usize))
            .zip(0..)
        {
            s.spawn(move || {
                for (i, ((ta, tb), tc)) in ca
                    .iter_mut()
                    .zip(cb.iter_mut())
                    .zip(cc.iter_mut())
                    .enumerate()
                {
                    let idx = chunk * rows_per * w as usize + i;
                    let (x, y) = ((idx % w as usize) as f32, (idx / w as usize) as f32);
                    let uv = Vec2::new((x + 0.5) / w as f32, 1.0 - (y + 0.5) / h as f32);
                    let [p, q, r] = f(uv);
                    (*ta, *tb, *tc) = (p, q, r);
                }
            });
        }
    });
    out
}

/// Gives the transparent texels (front alpha < 0.5) of all three maps the mean colour of
/// the opaque ones, so that bilinear filtering and mip levels at the matte's edge blend
/// leaf with leaf rather than with whatever the maps hold outside the blade (a bright rim
/// otherwise).
fn fill_transparent(maps: &mut [Vec<Texel>; 3]) {
    let opaque: Vec<bool> = maps[0].iter().map(|t| t[3] >= 0.5).collect();
    let n = opaque.iter().filter(|&&o| o).count();
    if n == 0 || n == opaque.len() {
        return;
    }
    for m in maps.iter_mut() {
        let mut mean = [0.0f64; 3];
        for (t, _) in m.iter().zip(&opaque).filter(|(_, o)| **o) {
            for c in 0..3 {
                mean[c] += t[c] as f64 / n as f64;
            }
        }
        for (t, _) in m.iter_mut().zip(&opaque).filter(|(_, o)| !**o) {
            for c in 0..3 {
                t[c] = mean[c] as f32;
            }
        }
    }
}

/// Lambertian angular tables (`1/pi` for the three lobes, no Fresnel).
fn lambert_lut() -> Vec<[f32; 4]> {
    let mut lut = vec![[std::f32::consts::FRAC_1_PI; 4]; LUT_N * LUT_N * LUT_LAYERS];
    for t in &mut lut[3 * LUT_N * LUT_N..] {
        *t = [0.0; 4];
    }
    lut
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

/// The shading constants of a leaf, from its parameters.
pub fn leaf_uniform(params: &LeafParams) -> MaterialUniform {
    MaterialUniform {
        spec: [
            params.roughness_adaxial,
            params.roughness_abaxial,
            params.specular,
            params.blend_width_deg.to_radians().sin(),
        ],
        shape: [0.0; 4],
    }
}

fn colour_size(c: &ColorInput) -> (u32, u32) {
    match c {
        ColorInput::Constant(_) => (1, 1),
        ColorInput::Texture { map, .. } => (map.width(), map.height()),
    }
}

/// Bakes one scene material under the texture side limit `max_dim`.
pub fn bake_material(material: &Material, max_dim: u32) -> BakedMaterial {
    let mut warnings = Vec::new();
    match material {
        Material::Leaf { name, leaf } => {
            let maps = leaf.maps();
            let (mut w, mut h) = (1, 1);
            for t in [
                &maps.front,
                &maps.back,
                &maps.translucency,
                &maps.alpha,
                &maps.thickness,
                &maps.extinction,
            ]
            .into_iter()
            .flatten()
            {
                w = w.max(t.width());
                h = h.max(t.height());
            }
            let (w, h) = fit(name, "the leaf maps", w, h, max_dim, &mut warnings);
            let leaf = leaf.clone();
            let mut maps = bake_texels(w, h, &move |uv| {
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
            let params = *leaf_params(material);
            BakedMaterial {
                name: name.clone(),
                front: mip_chain(w, h, f),
                back: mip_chain(w, h, b),
                trans: mip_chain(w, h, t),
                lut: leaf_lut(&params),
                uniform: leaf_uniform(&params),
                warnings,
            }
        }
        Material::Diffuse {
            name,
            reflectance,
            alpha,
        } => bake_diffuse(name, reflectance, None, alpha.as_ref(), max_dim, warnings),
        // Stand-in until the glossy bake lands: the base colour as a Lambertian.
        Material::Pbr(p) => bake_diffuse(
            &p.name,
            &p.base_color,
            None,
            p.alpha.as_ref(),
            max_dim,
            warnings,
        ),
        Material::DiffuseTransmission {
            name,
            reflectance,
            transmittance,
            alpha,
        } => bake_diffuse(
            name,
            reflectance,
            Some(transmittance),
            alpha.as_ref(),
            max_dim,
            warnings,
        ),
    }
}

fn leaf_params(m: &Material) -> &LeafParams {
    match m {
        Material::Leaf { leaf, .. } => leaf.params(),
        _ => unreachable!("only called for leaves"),
    }
}

fn bake_diffuse(
    name: &str,
    reflectance: &ColorInput,
    transmittance: Option<&ColorInput>,
    alpha: Option<&AlphaMask>,
    max_dim: u32,
    mut warnings: Vec<String>,
) -> BakedMaterial {
    let (mut w, mut h) = colour_size(reflectance);
    if let Some(t) = transmittance {
        let (tw, th) = colour_size(t);
        (w, h) = (w.max(tw), h.max(th));
    }
    if let Some(a) = alpha {
        (w, h) = (w.max(a.map.width()), h.max(a.map.height()));
    }
    let (w, h) = fit(name, "the colour/alpha maps", w, h, max_dim, &mut warnings);
    let mut maps = bake_texels(w, h, &|uv| {
        let r = reflectance.at(uv).clamp(Vec3::ZERO, Vec3::ONE);
        let t = transmittance.map_or(Vec3::ZERO, |t| t.at(uv).clamp(Vec3::ZERO, Vec3::ONE));
        let a = alpha.is_none_or(|m| m.opaque(uv));
        [
            [r.x, r.y, r.z, if a { 1.0 } else { 0.0 }],
            [r.x, r.y, r.z, 1.0],
            [t.x, t.y, t.z, 1.0],
        ]
    });
    fill_transparent(&mut maps);
    let [f, b, t] = maps;
    BakedMaterial {
        name: name.to_string(),
        front: mip_chain(w, h, f),
        back: mip_chain(w, h, b),
        trans: mip_chain(w, h, t),
        lut: lambert_lut(),
        uniform: MaterialUniform::default(),
        warnings,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
                    acc += Vec3::new(g[0], g[1], g[2])
                        * (2.0 * mi * 2.0 * std::f32::consts::PI * mo * w);
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
}
