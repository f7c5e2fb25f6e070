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
//! # glTF metallic-roughness materials ([`Material::Pbr`], [`lamina_leaf::PbrBsdf`])
//! * **Albedo maps**: `diffuse_albedo()` of `PbrMaterial::bsdf(uv)` at every texel centre
//!   over the largest of the base colour, metallic-roughness, transmission and alpha maps:
//!   `front` = `back` = the diffuse reflectance (the surface is two-sided; it already holds
//!   `1 − metallic`, `1 − transmission` and the `1 − E_avg` the specular coat takes),
//!   `trans` = the diffuse transmittance, alpha from the mask.
//! * **Specular**: one GGX lobe, the same on both sides, `alpha = r²` with `r` the mean
//!   perceptual roughness over the (opaque) texels, i.e. the factor times the mean of the
//!   roughness map: **per-texel roughness is averaged on the GPU** (per-texel metallic is
//!   not for the diffuse maps, only for the specular weights). The dielectric part has
//!   weight `1 − mean metallic` (`spec.z`) and the exact Fresnel of `max(ior, 1/ior)` in
//!   layer 3; the metallic part is carried by [`MaterialUniform::metal`] (mean
//!   `metallic · base_colour` and mean `metallic`), so metals get their coloured Schlick
//!   Fresnel as on the CPU. The blend width is [`PBR_BLEND_SIN`] (no fade: the CPU model has
//!   none).
//! * **Angular tables** ([`pbr_lut`]): the diffuse lobes' shape from the CPU model's
//!   public `eval` (the energy-conserving coupling `(1 − E(mu_o))(1 − E(mu_i))` makes them
//!   darker than Lambertian towards grazing), layer 3 the Fresnel, the dielectric
//!   specular albedo and (row 1) the metal albedo moments for the sky's reflection.
//! * **Normal map**: baked on its own grid (downscaled with a warning like the others) to
//!   a linear 8-bit map of the unit tangent-space normal with the map's scale applied
//!   (`rgb = n · 0.5 + 0.5`), `shape.y = 1`. The shader has no vertex tangents: it solves
//!   `dP/du`, `dP/dv` from the screen-space derivatives of position and uv (as the glTF
//!   sample viewer does without tangents) and builds lamina-render's frame (`x` = `dP/du`
//!   orthogonal to the normal, `y` towards increasing lamina `v`).
//!
//! # Leaf bump maps
//! A leaf with a bump map (and `bump_scale > 0`) gets it baked into the same normal map,
//! on the grid of its other maps (the bump map counts towards that grid's size and its
//! downscaling): at every texel centre the shading normal that
//! [`LeafMaterial::bsdf`] builds from the bump map's gradient (`LeafBsdf::shading_normal`,
//! so the formula, scale and clamp are lamina-leaf's), in the CPU leaf frame (`x` = `dP/du`,
//! `y` = `z × x`, which is towards increasing `v` unless the uv mapping is mirrored,
//! `z` = the adaxial normal). `shape.y = 1` as for glTF maps; `shape.z = 1` marks every
//! leaf, telling the shader that the normal map lives *inside* the BSDF as on the CPU:
//! adaxial/abaxial, reflection/transmission, the angular tables' cosines and the blend
//! band stay geometric, while the diffuse lobes' cosine becomes LeafBsdf's blended
//! shading cosine (`max(0, wi · ±n_s)`, `-n_s` on the abaxial side) and the specular lobe
//! and the sky's irradiance use `±n_s`. Leaves without a bump map keep the flat 1x1 map.
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
    /// on-axis form factor of a disc of radius `a`). `y`: 1 when the material has a
    /// tangent-space normal map (`BakedMaterial::normal`), else 0. `zw` unused.
    pub shape: [f32; 4],
    /// The metallic (coloured, Schlick-Fresnel) specular lobe of [`Material::Pbr`]: `rgb` =
    /// the mean of `metallic · base_colour` (the metal's F0 times its weight), `a` = the
    /// mean `metallic`; its Fresnel at `v·h` is `rgb + (a − rgb)(1 − v·h)⁵`. Zero for every
    /// other material.
    pub metal: [f32; 4],
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
    /// Tangent-space normal map, linear (`rgb = n · 0.5 + 0.5`, scale applied), used when
    /// `uniform.shape.y` is 1; a flat 1x1 map otherwise.
    pub normal: MipMap,
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
    mip_chain_with(width, height, base, encode)
}

/// Linear 8-bit encoding (normal maps).
fn encode_linear(c: Texel) -> [u8; 4] {
    c.map(|x| (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
}

/// The flat normal map of materials without one.
fn flat_normal() -> MipMap {
    mip_chain_with(1, 1, vec![[0.5, 0.5, 1.0, 1.0]], encode_linear)
}

/// [`mip_chain`] with the given 8-bit encoding.
fn mip_chain_with(
    width: u32,
    height: u32,
    base: Vec<Texel>,
    encode: fn(Texel) -> [u8; 4],
) -> MipMap {
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

/// The shading constants of a leaf, from its parameters: `shape.z = 1` marks the normal
/// map as a leaf bump map (sides and the angular tables stay geometric, the bump enters
/// the shading cosines and the specular lobe only); `shape.y` is set by [`bake_material`]
/// when the leaf has a bump map.
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
                &maps.bump,
            ]
            .into_iter()
            .flatten()
            {
                w = w.max(t.width());
                h = h.max(t.height());
            }
            let (w, h) = fit(name, "the leaf maps", w, h, max_dim, &mut warnings);
            let leaf: &LeafMaterial = leaf;
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
            let params = *leaf_params(material);
            let normal = leaf_bump_normals(leaf, w, h);
            let mut uniform = leaf_uniform(&params);
            if normal.is_some() {
                uniform.shape[1] = 1.0;
            }
            BakedMaterial {
                name: name.clone(),
                front: mip_chain(w, h, f),
                back: mip_chain(w, h, b),
                trans: mip_chain(w, h, t),
                normal: normal.unwrap_or_else(flat_normal),
                lut: leaf_lut(&params),
                uniform,
                warnings,
            }
        }
        Material::Diffuse {
            name,
            reflectance,
            alpha,
        } => bake_diffuse(name, reflectance, None, alpha.as_ref(), max_dim, warnings),
        Material::Pbr(p) => bake_pbr(p, max_dim, warnings),
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
        normal: flat_normal(),
        lut: lambert_lut(),
        uniform: MaterialUniform::default(),
        warnings,
    }
}

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
fn bake_pbr(
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
        let decode =
            |t: [u8; 4]| Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32) / 127.5 - Vec3::ONE;
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
}
